"""The test rig's simulator: an impulse train through a transfer path (McFadden & Smith 1984).

A record is built in five steps, none of which integrates equations of motion:

1. **Shaft angle.** The shaft turns at rpm / 60 Hz times a speed factor (1 unless an effect
   varies it); every rotating event is placed by the shaft angle, so speed changes move all of
   them together.
2. **Impacts.** A localized defect is struck at its characteristic order of the shaft angle
   (:meth:`RigBearing.orders`): outer race at BPFO, inner race at BPFI, a ball at 2 x BSF
   (alternately on the outer and the inner race). Each strike is a double event (Sawalhi &
   Randall 2011): at the leading edge the ball sinks in and sheds load smoothly over its fall,
   one crossing time (width / rolling speed) later it strikes the trailing edge and re-loads
   with an impact of ``RigSetup.impact_factor`` times the load it shed
   (:func:`~bearingtwin.testrig.path.strike_spectrum`). It sheds what its sink into the spall
   (the depth, at most the ball's sagitta over the width) relieves of its contact compression
   under the Stribeck / Harris load zone's ball load at the struck point
   (:mod:`~bearingtwin.testrig.loadzone`), at most all of it. The
   force acts along the radius through the struck point: fixed for the outer race, turning with
   the shaft for the inner race and with the cage for a ball, so both of those are modulated by
   the load zone and by the direction's projection on the sensor.
3. **Roughness.** A healthy bearing still rolls over roughness: a white random force in both
   directions, at a level independent of load and speed (a simplification).
4. **Path.** Impacts and roughness pass the contact ringing, the housing and the sensor mount
   (:class:`~bearingtwin.testrig.path.RigPath`), evaluated in the frequency domain.
5. **Sensor.** A small residual unbalance line (``RigSetup.residual_1x_db``, as every real rig
   has) and a white noise floor (``RigSetup.noise_floor_db``) below the bearing signal are
   added, with the effects' own components; then the cable and amplifier effects act, and the
   record is converted to the output unit and multiplied by the gain.

Randomness (initial angles, roughness, each effect's draws) comes from separate streams
derived from ``seed`` and a fixed label, so switching an effect on changes nothing else in the
record: the same seed with and without an effect differs by the effect alone.
"""

from __future__ import annotations

import math
import numbers
import zlib
from dataclasses import dataclass, fields
from typing import Mapping

import numpy as np

from bearingtwin.errors import BearingTwinError
from bearingtwin.testrig.effects import Noise, RigContext, Unbalance, build_rig_effects
from bearingtwin.testrig.geometry import RigBearing
from bearingtwin.testrig.loadzone import LoadZone, load_zone
from bearingtwin.testrig.path import RigPath, strike_spectrum

FAULTS = ("normal", "inner", "ball", "outer")
"""Bearing states the rig simulates (the same names the twin uses)."""

UNITS = {"m/s^2": 1.0, "g": 1.0 / 9.80665}
"""Output units and the factor from m/s^2 to each (standard gravity, 9.80665 m/s^2 per g)."""

LOAD_ANGLE_RAD = math.pi / 2.0
"""Direction of the radial load in the sensor frame: vertical, where sensor_angle_deg = 90 points."""


@dataclass(frozen=True)
class RigOperatingPoint:
    """How the rig is run and measured: what a twin fitted to the record should recover.

    The bearing's state and the random seed are :func:`simulate_rig`'s own arguments.

    Attributes:
        rpm: shaft speed, rev/min.
        fs: sampling rate, Hz.
        duration_s: record length, s.
        radial_load_n: radial load on the bearing, N (vertical).
        clearance_um: radial internal clearance, um (ISO 5753: total radial play; C0 of a 6205 is 5-20).
        sensor_angle_deg: sensor axis from the horizontal: 0 horizontal, 90 vertical (along the load).
        defect_width_mm: spall length along the rolling direction, mm (below the ball diameter).
        defect_depth_mm: spall depth, mm (a narrow spall is only felt to the ball's sagitta over it).
        defect_angle_deg: outer-race defect's position from the load zone's centre, deg (a defect
            outside the load zone carries no load and is not struck).
        gain: output per unit of ``unit`` (e.g. V per m/s^2; 1 for the physical value).
        unit: "m/s^2" or "g".
    """

    rpm: float = 1797.0
    fs: float = 12000.0
    duration_s: float = 1.0
    radial_load_n: float = 500.0
    clearance_um: float = 10.0
    sensor_angle_deg: float = 90.0
    defect_width_mm: float = 0.5
    defect_depth_mm: float = 0.1
    defect_angle_deg: float = 0.0
    gain: float = 1.0
    unit: str = "m/s^2"

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name != "unit" and not (isinstance(value, numbers.Real) and math.isfinite(value)):
                self._fail(f.name, "be a finite number")
        for name in ("rpm", "fs", "duration_s", "radial_load_n", "defect_width_mm", "defect_depth_mm"):
            if not getattr(self, name) > 0:
                self._fail(name, "be positive")
        if self.clearance_um < 0:
            self._fail("clearance_um", "not be negative")
        if self.gain == 0:
            self._fail("gain", "not be zero")
        if self.unit not in UNITS:
            self._fail("unit", f"be one of {', '.join(map(repr, UNITS))}")
        if self.n_samples < 256:
            self._fail("duration_s", f"give at least 256 samples at fs={self.fs}")

    def _fail(self, field: str, requirement: str) -> None:
        raise BearingTwinError(f"operating_point.{field} must {requirement}, got {getattr(self, field)!r}")

    @property
    def n_samples(self) -> int:
        return int(round(self.duration_s * self.fs))


@dataclass(frozen=True)
class RigSetup:
    """What is fixed about the rig rather than set per run.

    Attributes:
        bearing: the bearing's geometry and contact law.
        path: the mechanical path to the sensor.
        impact_factor: exit-impact force per newton of ball load the ball shed in the spall
            (a short impact exceeds the quasi-static load).
        inner_race_transmission: share of an impact on the inner race that reaches the housing
            (it crosses the rotor and the other balls).
        roughness_psd_n2_per_hz: one-sided power spectral density of the roughness force per direction.
        residual_1x_db: residual unbalance line relative to the bearing signal's RMS, dB; None: none.
        noise_floor_db: white sensor noise floor relative to the bearing signal's RMS, dB.
    """

    bearing: RigBearing = RigBearing()
    path: RigPath = RigPath()
    impact_factor: float = 2.0
    inner_race_transmission: float = 0.6
    roughness_psd_n2_per_hz: float = 1e-4
    residual_1x_db: float | None = -20.0
    noise_floor_db: float = -40.0


def _stream(seed: int, label: str) -> np.random.Generator:
    """An independent random stream for one purpose of one record."""
    return np.random.default_rng([seed, zlib.crc32(label.encode())])


def _impulse_train(times_s: np.ndarray, weights: np.ndarray, n_samples: int, fs: float) -> np.ndarray:
    """Unit impulses of the given weights at fractional sample times, split linearly between neighbours.

    Times wrap around the record: the rig's records are periodic by construction (frequency-domain
    convolution), so an impact near the end rings on at the start.
    """
    position = times_s * fs
    lower = np.floor(position)
    fraction = position - lower
    lower = lower.astype(np.int64)
    train = np.zeros(n_samples)
    np.add.at(train, lower % n_samples, weights * (1.0 - fraction))
    np.add.at(train, (lower + 1) % n_samples, weights * fraction)
    return train


@dataclass(frozen=True)
class _Strikes:
    """Strikes of a defect: entry times, struck-point angles (sensor frame) and shed ball loads (N)."""

    times_s: np.ndarray
    angles_rad: np.ndarray
    shed_n: np.ndarray


def _strikes(fault: str, op: RigOperatingPoint, setup: RigSetup, zone: LoadZone, t_s: np.ndarray,
             shaft_revs: np.ndarray, effects, seed: int) -> _Strikes:
    """When, where and how hard the defect of ``fault`` is struck over the record."""
    rng = _stream(seed, "strikes")
    orders = setup.bearing.orders()
    order = {"outer": orders["bpfo"], "inner": orders["bpfi"], "ball": 2.0 * orders["bsf"]}[fault]
    event_phase = order * shaft_revs + rng.uniform()
    index = np.arange(math.ceil(event_phase[0]), math.floor(event_phase[-1]) + 1)
    times = np.interp(index, event_phase, t_s)
    if fault != "ball":
        for effect in effects:
            times = effect.modify_impact_times(times, _stream(seed, effect.name + ".impact_times"))
    revs = np.interp(times, t_s, shaft_revs)
    start_rad = rng.uniform(0.0, 2.0 * math.pi)
    if fault == "outer":
        psi = np.full(times.size, math.radians(op.defect_angle_deg))
    elif fault == "inner":
        psi = start_rad + 2.0 * math.pi * revs
    else:
        psi = start_rad + 2.0 * math.pi * orders["ftf"] * revs
    load = zone.ball_load_n(psi)
    # The ball sinks into the spall by the drop, relieving that much of its contact compression:
    # by the contact law Q = K delta^n it keeps K (delta - drop)^n, and nothing once drop >= delta.
    stiffness, exponent = setup.bearing.contact_stiffness_n_per_m1_5, setup.bearing.load_exponent
    deflection = (load / stiffness) ** (1.0 / exponent)
    drop = setup.bearing.spall_drop_m(op.defect_width_mm, op.defect_depth_mm)
    shed = load - stiffness * np.clip(deflection - drop, 0.0, None) ** exponent
    if fault == "inner":
        shed = shed * setup.inner_race_transmission
    elif fault == "ball":
        # Even strikes on the outer race, odd ones on the inner race through the rotor.
        shed = np.where(index % 2 == 1, setup.inner_race_transmission, 1.0) * shed
    return _Strikes(times, LOAD_ANGLE_RAD + psi, shed)


def _force_spectra(strikes: _Strikes | None, op: RigOperatingPoint, setup: RigSetup, path: RigPath,
                   freqs_hz: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """DFTs of the force samples on the bearing in x and y: roughness plus the strikes."""
    n, fs = op.n_samples, op.fs
    rng = _stream(seed, "roughness")
    roughness_std = math.sqrt(setup.roughness_psd_n2_per_hz * fs / 2.0)
    spectra = [np.fft.rfft(roughness_std * rng.standard_normal(n)) for _ in range(2)]
    if strikes is None:
        return spectra[0], spectra[1]
    # One strike shape at the nominal rolling speed: a speed fluctuation of a few per cent moves
    # the strikes' timing (kept, through the shaft angle) far more than it changes their shape.
    bearing = setup.bearing
    rolling_m_s = bearing.rolling_speed_m_s(op.rpm / 60.0)
    fall_m = bearing.fall_distance_m(bearing.spall_drop_m(op.defect_width_mm, op.defect_depth_mm))
    strike = fs * strike_spectrum(freqs_hz, op.defect_width_mm * 1e-3 / rolling_m_s, fall_m / rolling_m_s,
                                  path.impact_duration_s(), setup.impact_factor)
    for axis, direction in enumerate((np.cos(strikes.angles_rad), np.sin(strikes.angles_rad))):
        train = _impulse_train(strikes.times_s, strikes.shed_n * direction, n, fs)
        spectra[axis] = spectra[axis] + strike * np.fft.rfft(train)
    return spectra[0], spectra[1]


def simulate_rig(fault: str = "normal", operating_point: RigOperatingPoint | None = None,
                 effects: Mapping[str, Mapping] | None = None, seed: int = 0,
                 setup: RigSetup = RigSetup()) -> np.ndarray:
    """One record of the test rig's accelerometer.

    Args:
        fault: "normal", "inner", "ball" or "outer".
        operating_point: speed, sampling, load, clearance, sensor and defect (defaults: :class:`RigOperatingPoint`).
        effects: ``{name: {parameter: value}}`` for effects to hide in the record (see ``RIG_EFFECTS``);
            an empty parameter mapping takes the effect's defaults.
        seed: non-negative integer; the same seed gives the same record.
        setup: the rig's fixed properties.

    Returns:
        (n_samples,) float64 record in ``operating_point.unit`` times ``operating_point.gain``.
    """
    if fault not in FAULTS:
        raise BearingTwinError(f"fault={fault!r} is not a bearing state; choose one of {', '.join(FAULTS)}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BearingTwinError(f"seed must be a non-negative integer, got {seed!r}")
    op = RigOperatingPoint() if operating_point is None else operating_point
    built = build_rig_effects(effects)
    n, fs = op.n_samples, op.fs
    t_s = np.arange(n) / fs
    shaft_hz = op.rpm / 60.0

    speed = np.ones(n)
    for effect in built:
        speed = effect.modify_speed(speed, t_s, _stream(seed, effect.name + ".speed"))
    shaft_revs = shaft_hz * np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]))]) / fs

    zone = load_zone(setup.bearing, op.radial_load_n, op.clearance_um)
    path = setup.path
    for effect in built:
        path = effect.modify_path(path)
    path.check_nyquist(fs)

    freqs_hz = np.fft.rfftfreq(n, d=1.0 / fs)
    strikes = None if fault == "normal" else _strikes(fault, op, setup, zone, t_s, shaft_revs, built, seed)
    force_x, force_y = _force_spectra(strikes, op, setup, path, freqs_hz, seed)
    from_x, from_y = path.sensor_frf(freqs_hz, math.radians(op.sensor_angle_deg))
    ringing = path.contact_transmissibility(freqs_hz, zone.radial_stiffness_n_per_m)
    bearing_signal = np.fft.irfft(ringing * (from_x * force_x + from_y * force_y), n=n)

    shaft_angle = 2.0 * math.pi * shaft_revs + _stream(seed, "shaft").uniform(0.0, 2.0 * math.pi)
    context = RigContext(fs=fs, shaft_angle_rad=shaft_angle, speed_ratio=speed, shaft_hz=shaft_hz,
                         reference_rms=math.sqrt(float(np.mean(bearing_signal**2))))
    record = bearing_signal + Noise(snr_db=-setup.noise_floor_db, spectral_slope=0.0).component(
        context, _stream(seed, "noise_floor"))
    if setup.residual_1x_db is not None:
        record += Unbalance(level_db=setup.residual_1x_db).component(context, _stream(seed, "residual_1x"))
    for effect in built:
        added = effect.component(context, _stream(seed, effect.name + ".component"))
        if added is not None:
            record = record + added
    for effect in built:
        record = effect.modify_record(record, context, _stream(seed, effect.name + ".record"))
    return record * UNITS[op.unit] * op.gain
