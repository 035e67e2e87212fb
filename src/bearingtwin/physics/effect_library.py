"""The effects a measured bearing shows and the bare twin does not.

Each effect is a small class with one or two physically meaningful parameters and
acts at the stage of the twin where the physics happens (see
:mod:`bearingtwin.physics.effects`): the sensor path (``resonance``,
``second_resonance``, ``noise``, ``tones``, ``clipping``), the kinematics the solver
reads (``slip``, ``spin_slip``, ``speed_fluctuation``) or the dynamic parameters
(``lubrication``, ``load_zone``, ``preload``). The sensor-path physics is also exposed as
plain signal functions (arrays in, arrays out, batched along the leading axis) so it can
be used and tested without a simulator. Sensor-path effects cost the twin a filter, not
a simulation, so whatever physics allows is modelled there.

Adding an effect is one class decorated with ``@register_effect`` and one
``conf/effects/<name>.yaml``; comparison, calibration and ranking pick it up by name.
Every class documents the signature it leaves in a measurement, which is what
:mod:`bearingtwin.twin.rank` reports as evidence.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import signal as sps

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.dynamics import DynamicParameters
from bearingtwin.physics.effects import Effect, register_effect
from bearingtwin.physics.kinematics import Kinematics


def _positive(field: str, value: float) -> float:
    if not (np.isfinite(value) and value > 0):
        raise BearingTwinError(f"{field} must be a positive number, got {value}")
    return float(value)


def base_excitation_filter(x: np.ndarray, fs: float, natural_frequency_hz: float, damping_ratio: float,
                           effect: str = "resonance") -> np.ndarray:
    """Absolute acceleration of a sensor mount driven by the bearing housing's acceleration.

    The mount is a single-degree-of-freedom oscillator excited at its base, so its
    transmissibility is (2 zeta wn s + wn^2) / (s^2 + 2 zeta wn s + wn^2): unity far below
    ``natural_frequency_hz``, a peak of about 1 / (2 zeta) at it, -20 dB/decade above.
    The bilinear transform is prewarped at the natural frequency so the peak stays at
    the right place for any sampling rate ``fs`` (Hz). Filters along the last axis; errors
    name the parameters as those of ``effect``.
    """
    fs = _positive("fs", fs)
    natural_frequency_hz = _positive(f"{effect}.natural_frequency_hz", natural_frequency_hz)
    damping_ratio = _positive(f"{effect}.damping_ratio", damping_ratio)
    if natural_frequency_hz >= fs / 2:
        raise BearingTwinError(
            f"{effect}.natural_frequency_hz={natural_frequency_hz} must lie below the Nyquist frequency {fs / 2} Hz"
        )
    wn = 2 * math.pi * natural_frequency_hz
    k = wn / math.tan(wn / (2 * fs))
    b1, b0 = 2 * damping_ratio * wn, wn**2
    a1, a0 = 2 * damping_ratio * wn, wn**2
    num = np.array([b1 * k + b0, 2 * b0, b0 - b1 * k])
    den = np.array([k**2 + a1 * k + a0, 2 * a0 - 2 * k**2, k**2 - a1 * k + a0])
    return sps.lfilter(num / den[0], den / den[0], np.asarray(x, dtype=np.float64), axis=-1)


def coloured_noise(shape: tuple[int, ...], fs: float, spectral_slope: float, rng: np.random.Generator) -> np.ndarray:
    """Zero-mean Gaussian noise of unit variance whose power density falls as f^-spectral_slope.

    ``spectral_slope`` 0 is white (electronic sensor noise), 1 is pink (background
    machinery, flow); the last axis is time sampled at ``fs`` Hz. The lowest bin takes the
    level of the first non-zero frequency so a steep slope cannot blow up at DC.
    """
    n = shape[-1]
    spectrum = np.fft.rfft(rng.standard_normal(shape), axis=-1)
    freqs_hz = np.fft.rfftfreq(n, d=1.0 / fs)
    freqs_hz[0] = freqs_hz[1] if n > 1 else 1.0
    noise = np.fft.irfft(spectrum * freqs_hz ** (-spectral_slope / 2.0), n=n, axis=-1)
    noise -= noise.mean(axis=-1, keepdims=True)
    return noise / np.maximum(noise.std(axis=-1, keepdims=True), np.finfo(float).tiny)


def add_noise(x: np.ndarray, fs: float, snr_db: float, spectral_slope: float, rng: np.random.Generator,
              reference_rms: float | None = None) -> np.ndarray:
    """``x`` plus coloured noise at a signal-to-noise power ratio of ``snr_db`` (per signal, last axis).

    The signal power the ratio refers to is each signal's own, or ``reference_rms`` squared
    when given (same units as ``x``): then every signal gets noise of the same absolute level,
    as a sensor's noise floor does whatever the bearing's state.
    """
    if not np.isfinite(snr_db):
        raise BearingTwinError(f"noise.snr_db must be finite, got {snr_db}")
    x = np.asarray(x, dtype=np.float64)
    if reference_rms is None:
        rms = np.sqrt(np.mean(x**2, axis=-1, keepdims=True))
    else:
        rms = _positive("noise.reference_rms", reference_rms)
    return x + rms * 10 ** (-snr_db / 20.0) * coloured_noise(x.shape, fs, spectral_slope, rng)


def add_tones(
    x: np.ndarray,
    fs: float,
    frequency_hz: float,
    level_db: float,
    n_harmonics: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """``x`` plus a family of discrete lines at k * ``frequency_hz``, k = 1..``n_harmonics``.

    The fundamental's amplitude is ``level_db`` relative to the RMS of ``x``; harmonic k has
    1/k of it (the spectrum of a distorted periodic force: supply-frequency magnetic pull,
    shaft unbalance and misalignment). Phases are random (drawn from ``rng``) because they
    are not observable in a spectrum. Lines at or above the Nyquist frequency are left out.
    """
    frequency_hz = _positive("tones.frequency_hz", frequency_hz)
    if n_harmonics < 1:
        raise BearingTwinError(f"tones.n_harmonics must be at least 1, got {n_harmonics}")
    x = np.asarray(x, dtype=np.float64)
    t = np.arange(x.shape[-1]) / fs
    rms = np.sqrt(np.mean(x**2, axis=-1, keepdims=True))
    amplitude = rms * math.sqrt(2.0) * 10 ** (level_db / 20.0)
    lines = np.zeros(x.shape[-1])
    for k in range(1, n_harmonics + 1):
        if k * frequency_hz < fs / 2:
            lines += np.cos(2 * math.pi * k * frequency_hz * t + rng.uniform(0, 2 * math.pi)) / k
    return x + amplitude * lines


def clip_at_rms(x: np.ndarray, clip_level: float) -> np.ndarray:
    """``x`` limited to +- ``clip_level`` times its RMS (per signal, last axis): a saturated sensor."""
    clip_level = _positive("clipping.clip_level", clip_level)
    x = np.asarray(x, dtype=np.float64)
    limit = clip_level * np.sqrt(np.mean(x**2, axis=-1, keepdims=True))
    return np.clip(x, -limit, limit)


def _fluctuated_angle(angle_rad: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """An unwrapped angle series whose rate is multiplied by ``factor`` (per interval), same start."""
    steps = np.diff(angle_rad) * 0.5 * (factor[1:] + factor[:-1])
    return angle_rad[0] + np.concatenate([[0.0], np.cumsum(steps)])


@register_effect
class Resonance(Effect):
    """Transmission path from the bearing to the sensor: a mount or housing mode.

    Args:
        natural_frequency_hz: the path's natural frequency (accelerometer mounts and housings:
            1-6 kHz).
        damping_ratio: its damping ratio zeta (0.02-0.1 for bolted steel).

    Signature: a band of raised energy around the natural frequency (peak gain ~1/(2 zeta))
    and a roll-off above it in the PSD; impacts ring at the natural frequency.
    """

    name = "resonance"
    signature = "band energy around the natural frequency"
    search_space = {"natural_frequency_hz": (300.0, 5000.0, True), "damping_ratio": (0.01, 0.3, True)}

    def __init__(self, natural_frequency_hz: float, damping_ratio: float):
        self.natural_frequency_hz = _positive(f"{self.name}.natural_frequency_hz", natural_frequency_hz)
        self.damping_ratio = _positive(f"{self.name}.damping_ratio", damping_ratio)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return base_excitation_filter(signal, fs, self.natural_frequency_hz, self.damping_ratio, self.name)


@register_effect
class SecondResonance(Resonance):
    """A second mode of the transmission path, in series with ``resonance``'s (same filter).

    Housing and mount each have a mode, and a bolted sensor sees both: the path's
    transmissibility is the product of two base-excitation filters. Offered alone, the
    ranking could not tell this mode from the first (``resonance`` explains a lone mode
    equally well), so it ``requires`` ``resonance`` to be in the twin already.

    Args:
        natural_frequency_hz: the second mode's natural frequency (0.3-6 kHz; below or above
            the first).
        damping_ratio: its damping ratio zeta (0.01-0.1).

    Signature: a second band of raised energy (peak gain ~1/(2 zeta)) where the twin with one
    resonance is short of energy; impacts ring at two frequencies.
    """

    name = "second_resonance"
    requires = ("resonance",)
    signature = "a second band of raised energy around its natural frequency"


@register_effect
class Slip(Effect):
    """Random rolling-element slip: each ball wanders in its cage pocket instead of rolling ideally.

    Every ball gets a random angular offset, redrawn once per ball pass (the time the cage
    takes to advance one ball spacing, 2 pi / Nb) and interpolated linearly in between, with
    standard deviation ``jitter`` x 2 pi / Nb. Since consecutive impacts are one ball spacing
    apart, ``jitter`` is the standard deviation of the impact times as a fraction of the
    nominal impact spacing (Randall & Antoni: typically 0.01-0.02). Race defects only: a ball
    defect's impacts follow the ball's spin, which this slip leaves unchanged.

    Signature: the impacts lose strict periodicity, so envelope-spectrum harmonics weaken with
    order and a random floor rises between them; band energies hardly change.
    """

    name = "slip"
    signature = "envelope harmonics sink into a raised random floor"
    search_space = {"jitter": (0.002, 0.08, True)}

    def __init__(self, jitter: float):
        self.jitter = _positive("slip.jitter", jitter)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        n, n_balls = kinematics.n_samples, kinematics.n_balls
        spacing_rad = 2 * math.pi / n_balls
        cage_step_rad = abs(kinematics.cage_angle_rad[-1] - kinematics.cage_angle_rad[0]) / max(n - 1, 1)
        samples_per_pass = spacing_rad / cage_step_rad
        n_knots = int(math.ceil((n - 1) / samples_per_pass)) + 2
        knots = rng.normal(0.0, self.jitter * spacing_rad, size=(n_knots, n_balls))
        position = np.arange(n) / samples_per_pass
        lower = np.floor(position).astype(int)
        fraction = (position - lower)[:, None]
        offsets = knots[lower] * (1 - fraction) + knots[lower + 1] * fraction
        return replace(kinematics, ball_offset_rad=kinematics.ball_offset_rad + offsets)


@register_effect
class SpinSlip(Effect):
    """Erratic ball spin: a ball defect strikes the races at irregular times.

    A ball's spin axis is not fixed: the ball skids and its axis precesses, so a spall on
    it leaves and re-enters the rolling track and its strikes lose the strict 2 x BSF
    rhythm (Randall & Antoni 2011, section 2.2: ball faults "may not strike the races every
    revolution"). Modelled as a random walk of the spin angle: once per spin revolution the
    phase takes a Gaussian step of standard deviation ``jitter`` x 2 pi, linearly interpolated
    in between. Race defects are unaffected (their impacts follow the cage and the shaft).

    Signature: the 2 x BSF envelope lines smear into a raised floor, while the cage-rate (FTF)
    modulation of a ball defect passing through the load zone survives.
    """

    name = "spin_slip"
    signature = "2 x BSF envelope lines smear, cage-rate modulation stays"
    search_space = {"jitter": (0.005, 0.5, True)}

    def __init__(self, jitter: float):
        self.jitter = _positive("spin_slip.jitter", jitter)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        spin = kinematics.ball_spin_angle_rad
        revolutions = abs(spin[-1] - spin[0]) / (2 * math.pi)
        position = np.abs(spin - spin[0]) / (2 * math.pi)  # spin revolutions so far, per sample
        knots = np.concatenate([[0.0], np.cumsum(rng.normal(0.0, self.jitter * 2 * math.pi,
                                                            size=int(math.ceil(revolutions)) + 1))])
        walk = np.interp(position, np.arange(len(knots)), knots)
        return replace(kinematics, ball_spin_angle_rad=spin + walk)


@register_effect
class SpeedFluctuation(Effect):
    """Periodic variation of the shaft speed (load torque ripple, a coupling, a belt).

    omega(t) = omega_0 (1 + depth sin(2 pi frequency_hz t + phi)), phi random; cage and ball
    spin follow the shaft in proportion (rolling without slip), and so does the unbalance force.

    Args:
        depth: peak relative speed deviation (0.005-0.05).
        frequency_hz: modulation frequency (0.5-20 Hz: once per revolution or slower).

    Signature: every defect harmonic k f_d is frequency-modulated, giving sidebands at
    +- frequency_hz whose spread grows with k (k f_d depth / frequency_hz).
    """

    name = "speed_fluctuation"
    signature = "sidebands and smearing growing with harmonic order"
    search_space = {"depth": (0.002, 0.08, True), "frequency_hz": (0.5, 30.0, True)}

    def __init__(self, depth: float, frequency_hz: float):
        self.depth = _positive("speed_fluctuation.depth", depth)
        if self.depth >= 1:
            raise BearingTwinError(f"speed_fluctuation.depth must be below 1 (the shaft would stop), got {depth}")
        self.frequency_hz = _positive("speed_fluctuation.frequency_hz", frequency_hz)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        t = np.arange(kinematics.n_samples) / kinematics.fs_hz
        factor = 1.0 + self.depth * np.sin(2 * math.pi * self.frequency_hz * t + rng.uniform(0, 2 * math.pi))
        return replace(
            kinematics,
            shaft_angle_rad=_fluctuated_angle(kinematics.shaft_angle_rad, factor),
            shaft_speed_rad_s=kinematics.shaft_speed_rad_s * factor,
            cage_angle_rad=_fluctuated_angle(kinematics.cage_angle_rad, factor),
            ball_spin_angle_rad=_fluctuated_angle(kinematics.ball_spin_angle_rad, factor),
        )


@register_effect
class Noise(Effect):
    """Sensor and background noise: electronics (white) and machinery or flow (falling with frequency).

    Args:
        snr_db: ratio of the bearing signal's power to the noise power, in dB.
        spectral_slope: exponent of the noise PSD ~ f^-slope (0 white, 1 pink, 2 brown).
        reference_rms: the signal RMS (m/s^2) that ``snr_db`` refers to; null = each simulated
            signal's own. Fitted on one record, the noise is a property of the sensor and the
            machine, not of the bearing's state: ``data=twin_to_real`` sets this to the healthy
            twin's RMS so that a faulty twin gets the healthy record's noise floor, not one
            scaled up with its own fault.

    Signature: a raised floor in the bands where the bearing is quiet, lower kurtosis and
    crest factor, a raised envelope-spectrum floor.
    """

    name = "noise"
    signature = "raised floor in quiet bands, lower kurtosis"
    search_space = {"snr_db": (-10.0, 30.0, False), "spectral_slope": (0.0, 2.0, False)}

    def __init__(self, snr_db: float, spectral_slope: float, reference_rms: float | None = None):
        if not np.isfinite(snr_db):
            raise BearingTwinError(f"noise.snr_db must be finite, got {snr_db}")
        if not 0.0 <= spectral_slope <= 3.0:
            raise BearingTwinError(f"noise.spectral_slope must lie in [0, 3], got {spectral_slope}")
        self.snr_db, self.spectral_slope = float(snr_db), float(spectral_slope)
        self.reference_rms = None if reference_rms is None else _positive("noise.reference_rms", reference_rms)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return add_noise(signal, fs, self.snr_db, self.spectral_slope, rng, self.reference_rms)


@register_effect
class Tones(Effect):
    """Discrete lines from the motor and the shaft: supply-frequency harmonics, unbalance, misalignment.

    Args:
        frequency_hz: fundamental of the line family (supply frequency or twice it for the
            magnetic pull, e.g. 60 or 120 Hz; shaft rate for unbalance).
        level_db: fundamental's amplitude relative to the bearing signal's RMS, in dB.
        n_harmonics: lines at 1..n_harmonics times the fundamental, amplitude 1/k (fixed, not fitted).

    Signature: narrow lines at low frequency in the PSD, unrelated to the defect frequency.
    """

    name = "tones"
    signature = "low-frequency band energy in discrete lines"
    search_space = {"frequency_hz": (10.0, 400.0, True), "level_db": (-20.0, 30.0, False)}

    def __init__(self, frequency_hz: float, level_db: float, n_harmonics: int = 3):
        self.frequency_hz = _positive("tones.frequency_hz", frequency_hz)
        if not np.isfinite(level_db):
            raise BearingTwinError(f"tones.level_db must be finite, got {level_db}")
        if int(n_harmonics) != n_harmonics or n_harmonics < 1:
            raise BearingTwinError(f"tones.n_harmonics must be a positive integer, got {n_harmonics}")
        self.level_db, self.n_harmonics = float(level_db), int(n_harmonics)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return add_tones(signal, fs, self.frequency_hz, self.level_db, self.n_harmonics, rng)


@register_effect
class Clipping(Effect):
    """Sensor saturation: the recorded signal is the true one limited to the sensor's range.

    An accelerometer's amplifier or the acquisition's converter stops at its full-scale
    range. Modelled as a hard limit, not a soft one (tanh): a converter's full scale is
    exact and an IEPE amplifier stays linear almost to its rail, which is what saturated
    records show, flat tops. The range is given relative to the RMS of the signal reaching
    the sensor, because the twin's absolute scale is the fitted sensor gain.

    Args:
        clip_level: the range as a multiple of the signal's RMS (1-10; impacts of a defect
            reach 4-10 times the RMS, so a clip level of a few RMS cuts them).

    Signature: flat-topped peaks; lower kurtosis and crest factor; the clipped impacts'
    energy spreads to odd harmonics and a broadband floor.
    """

    name = "clipping"
    signature = "flat-topped peaks, lower kurtosis and crest factor"
    search_space = {"clip_level": (1.0, 10.0, True)}

    def __init__(self, clip_level: float):
        self.clip_level = _positive("clipping.clip_level", clip_level)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return clip_at_rms(signal, self.clip_level)


@register_effect
class LoadZone(Effect):
    """Radial load on the shaft and the diametral clearance, which together set the load zone.

    Args:
        radial_load_n: downward radial load on the inner race in N (belt pull, rotor weight
            beyond the model's); replaces ``simulator.load_y_n``.
        clearance_um: radial internal clearance in micrometres: the larger it is for a given
            load, the fewer balls carry it and the narrower the load zone.

    Signature: impacts are strong only inside the load zone, so a rotating defect (inner race:
    shaft rate, ball: cage rate) is amplitude-modulated: sidebands around the defect
    harmonics; the contact stiffness, hence the race modes, shifts with load.
    """

    name = "load_zone"
    signature = "modulation sidebands and shifted race modes"
    search_space = {"radial_load_n": (10.0, 5000.0, True), "clearance_um": (0.5, 40.0, True)}

    def __init__(self, radial_load_n: float, clearance_um: float):
        if not np.isfinite(radial_load_n) or radial_load_n < 0:
            raise BearingTwinError(f"load_zone.radial_load_n must be a non-negative number, got {radial_load_n}")
        if not np.isfinite(clearance_um) or clearance_um < 0:
            raise BearingTwinError(f"load_zone.clearance_um must be a non-negative number, got {clearance_um}")
        self.radial_load_n, self.clearance_um = float(radial_load_n), float(clearance_um)

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return replace(params, load_y_n=-self.radial_load_n, clearance_m=self.clearance_um * 1e-6)


@register_effect
class Preload(Effect):
    """A preloaded bearing: every ball is compressed, so the load zone spans the whole circle.

    Motor bearings are usually held by an axial wave spring (or fitted with interference),
    which presses every ball against both races. In this radial model that is a negative
    internal clearance: each ball starts ``interference_um`` compressed, so the radial load
    only varies the ball loads around the circle instead of unloading half of them.

    Args:
        interference_um: radial compression of every ball at rest, in micrometres; replaces
            the clearance (a ball carrying ~1 kN of a 6205's load sinks ~20 um, so a few tens
            of micrometres keep every ball loaded).

    Signature: a rotating defect (inner race, ball) strikes at every position, so its
    shaft- or cage-rate modulation and the sidebands around its harmonics shrink, and the
    defect lines carry a larger share of the envelope.
    """

    name = "preload"
    signature = "modulation sidebands shrink, defect lines dominate the envelope"
    search_space = {"interference_um": (1.0, 60.0, True)}

    def __init__(self, interference_um: float):
        self.interference_um = _positive("preload.interference_um", interference_um)

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return replace(params, clearance_m=-self.interference_um * 1e-6)


@register_effect
class Lubrication(Effect):
    """Elastohydrodynamic oil film in the ball-race contacts.

    The pressurised film is a compliant, viscous layer in series with the dry Hertz
    contact: it lowers the contact stiffness and damps each loaded contact.

    Args:
        stiffness_ratio: contact stiffness with the film / dry Hertz stiffness (0.5-1).
        damping_ns_per_m: viscous damping of each loaded ball contact in N s/m, acting on the
            rate of contact deflection (tens to thousands of N s/m for grease to oil bath).

    Signature: the race-contact modes (a few hundred Hz in the paper's bearing) move down
    with the softer film and lose energy to its damping, while the sharp deflection rate at
    a pit still passes as force: the mode bands weaken and the impacts stand out more.
    """

    name = "lubrication"
    signature = "weaker, lower contact-mode bands; impacts stand out more"
    search_space = {"stiffness_ratio": (0.3, 1.0, False), "damping_ns_per_m": (1.0, 5000.0, True)}

    def __init__(self, stiffness_ratio: float, damping_ns_per_m: float):
        if not 0.0 < stiffness_ratio <= 1.0:
            raise BearingTwinError(f"lubrication.stiffness_ratio must lie in (0, 1], got {stiffness_ratio}")
        if not np.isfinite(damping_ns_per_m) or damping_ns_per_m < 0:
            raise BearingTwinError(
                f"lubrication.damping_ns_per_m must be a non-negative number, got {damping_ns_per_m}")
        self.stiffness_ratio, self.damping_ns_per_m = float(stiffness_ratio), float(damping_ns_per_m)

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return replace(params, contact_stiffness_n_per_m1_5=params.contact_stiffness_n_per_m1_5 * self.stiffness_ratio,
                       contact_damping_ns_per_m=params.contact_damping_ns_per_m + self.damping_ns_per_m)
