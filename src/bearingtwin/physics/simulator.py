"""The digital twin: bearing + simulator config (+ effects) in, vibration records out.

One simulation: build the dynamic parameters (effects may change them), the rigid
rolling kinematics on the solver's grid (effects may perturb them), solve the static
equilibrium so the bearing starts at rest under its load, integrate through a
start-up transient long enough for the slowest linearized mode to decay by
``simulator.settle_decades`` decades, and keep ``simulator.duration`` seconds of the
accelerations of the inner and outer race in x and y. The sensor channel
(``simulator.sensor``) then passes through the effects' sensor path.

The accelerations are samples of the solution at ``simulator.fs``, as the paper takes them:
what the contact dynamics put above fs/2 (the pit edges' transients) folds back below it.
``simulator.oversample`` = q > 1 solves on a grid q times finer and brings the races'
accelerations down to fs through an anti-aliasing filter, as an acquisition system's input
stage does before its converter (``scipy.signal.resample_poly``).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Mapping, NamedTuple, Sequence

import joblib
import numpy as np
import scipy.signal
from omegaconf import OmegaConf
from tqdm.auto import tqdm

from bearingtwin.checks import derived_seed, finite_number, is_finite_number, physical_memory_bytes, whole_number
from bearingtwin.config import CONF_DIR, closest_setting, plain_config
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics import solvers
from bearingtwin.physics.defects import Defect, build_defect, crossing_time_s
from bearingtwin.physics.dynamics import DynamicParameters, linear_modes, static_equilibrium
from bearingtwin.physics.effects import Effect, build_effects
from bearingtwin.physics.geometry import FAULT_FREQUENCY, FAULTS, BearingGeometry, check_fault
from bearingtwin.physics.kinematics import Kinematics, rigid_kinematics
from bearingtwin.physics.solvers import fast, reference

CHANNELS = ("inner_x", "inner_y", "outer_x", "outer_y")
"""Rows of the (4, n) acceleration array, and the values ``simulator.sensor`` accepts."""


MIN_SAMPLES = 2
"""Fewest samples a simulated record may have: one sample has no spectrum (the envelope that
``bearingtwin-simulate plot=true`` draws needs two), and none is no record."""

# Peak memory of one simulation, measured with tracemalloc (the peak traced while simulate() ran,
# after a first call had compiled the numba code) on the paper bearing at 10 kHz and 1 s (10.8k
# samples with the start-up transient), per sample of the kinematic grid (transient + record):
# fast solver, no effects: 146 B with 9 balls, 234 B with 20 (8 B per ball: the (n, Nb) ball-offset
# series); with the effects that rewrite the kinematics, slip the costliest (it alone, or with
# spin_slip and speed_fluctuation, or all sixteen effects in conf/effects, peak the same): 352 B
# with 9 balls, 707 B with 20, i.e. 61 + 32 Nb. The reference solver adds 521-535 B per recorded
# sample (solve_ivp's states and a derivative array per sample), measured over 0.1 s and 0.3 s.
# Rounded up to the factors below, the worst case for any effects (2.5 x the peak without them);
# the arrays the command keeps afterwards (40 B per sample) and its envelope plot stay below this.
# tests/test_simulator_input.py checks the estimate still bounds the traced peak.
_BYTES_PER_GRID_SAMPLE = 72
_BYTES_PER_GRID_SAMPLE_AND_BALL = 32
_BYTES_PER_REFERENCE_SAMPLE = 544

ANTI_ALIAS_HALF_LENGTH = 10
"""Output samples either side of a sample that ``scipy.signal.resample_poly``'s default
anti-aliasing filter reaches (its half-length is 10 x the down-sampling factor in input
samples): the oversampled solution extends this far beyond the record at both ends, so that
no edge of the filtered array falls inside it."""


def _record_samples(simulator_cfg: Mapping) -> int:
    """Samples in the kept record: ``simulator.duration`` x ``simulator.fs`` (positive, finite numbers)."""
    samples = simulator_cfg["duration"] * simulator_cfg["fs"]
    if not math.isfinite(samples):  # 1e200 s at 1e200 Hz: no integer, and no memory either
        raise BearingTwinError(f"simulator.fs={simulator_cfg['fs']:g} Hz x simulator.duration="
                               f"{simulator_cfg['duration']:g} s is more samples than any memory holds")
    return round(samples)


@functools.lru_cache(maxsize=1)
def declared_settings() -> dict:
    """Every setting the simulator reads, nested, with its default: ``conf/simulator/default.yaml`` as a plain dict
    (checked on every simulation: a config node's lookups cost a millisecond a time)."""
    return OmegaConf.to_container(OmegaConf.load(Path(CONF_DIR) / "simulator" / "default.yaml"))


def _check_declared(given: Mapping, declared: Mapping, prefix: str = "simulator") -> None:
    """Refuse a setting the simulator does not read: a misspelt ``durration`` would leave the default at work,
    unsaid."""
    for key, value in given.items():
        if key not in declared:
            hint = (closest_setting(OmegaConf.create({"simulator": declared_settings()}), f"{prefix}.{key}")
                    or f"its settings: {', '.join(declared)}")
            raise BearingTwinError(f"{prefix}.{key} is not a setting of the simulator; {hint}")
        if isinstance(declared[key], dict) and isinstance(value, Mapping):
            _check_declared(value, declared[key], f"{prefix}.{key}")


def _check_settings(simulator_cfg: Mapping) -> None:
    _check_declared(simulator_cfg, declared_settings())
    # A hand-written mapping may leave out a setting whose default is null; a defect's own are its to name.
    missing = [key for key, default in declared_settings().items() if key not in simulator_cfg and default is not None]
    if missing:
        raise BearingTwinError(f"simulator has no {', '.join(missing)}; a config composed from conf/ "
                               "(bearingtwin.config.compose_config('simulate')) holds every setting")
    for name in ("rpm", "fs", "duration", "settle_decades"):
        value = simulator_cfg[name]
        if not (is_finite_number(value) and value > 0):
            raise BearingTwinError(f"simulator.{name} must be a positive, finite number, got {value!r}")
    n_samples = _record_samples(simulator_cfg)
    if n_samples < MIN_SAMPLES:
        duration, fs = simulator_cfg["duration"], simulator_cfg["fs"]
        raise BearingTwinError(
            f"simulator.duration={duration:g} s at simulator.fs={fs:g} Hz gives {n_samples} sample"
            f"{'' if n_samples == 1 else 's'}; a record "
            f"needs at least {MIN_SAMPLES}: make simulator.duration at least {MIN_SAMPLES / fs:g} s"
        )
    if simulator_cfg["solver"] not in solvers.SOLVERS:
        raise BearingTwinError(f"simulator.solver={simulator_cfg['solver']!r}: choose one of {', '.join(solvers.SOLVERS)}")
    if simulator_cfg["solver"] == "fast":
        for name in ("steps_per_period", "steps_per_defect"):
            whole_number(f"simulator.fast.{name}", simulator_cfg["fast"][name])
    else:
        whole_number("simulator.reference.steps_per_defect", simulator_cfg["reference"]["steps_per_defect"])
    if simulator_cfg["sensor"] not in CHANNELS:
        raise BearingTwinError(f"simulator.sensor={simulator_cfg['sensor']!r}: choose one of {', '.join(CHANNELS)}")
    angle = simulator_cfg.get("sensor_angle_deg")
    if angle is not None:
        finite_number("simulator.sensor_angle_deg", angle, "null or a finite angle in degrees")
    finite_number("simulator.initial_cage_angle_deg", simulator_cfg["initial_cage_angle_deg"],
                  "a finite angle in degrees")
    whole_number("simulator.seed", simulator_cfg["seed"], minimum=0)  # numpy's SeedSequence takes no negative seed
    oversample_factor(simulator_cfg)


def oversample_factor(simulator_cfg: Mapping) -> int:
    """``simulator.oversample`` checked as a positive whole number; null, or absent from a config written
    before it existed, is 1 (samples of the solution at fs)."""
    value = simulator_cfg.get("oversample")
    return 1 if value is None else whole_number("simulator.oversample", value, minimum=1)


def records_identity(simulator_cfg: Mapping) -> dict:
    """The simulator config as a cache of simulated records is keyed by: ``oversample`` left out where it is 1
    (null), which computes what its absence did, so records simulated before it existed keep their keys."""
    unset = oversample_factor(simulator_cfg) == 1
    return {name: value for name, value in simulator_cfg.items() if not (name == "oversample" and unset)}


def _check_resolves_fault(fault: str, geometry: BearingGeometry, rpm: float, fs: float, duration_s: float) -> None:
    """Refuse a sampling rate whose Nyquist frequency does not clear the fault's defect frequency, and a
    speed and duration in which the defect is not struck once (the record would be a healthy bearing's)."""
    frequency = geometry.fault_frequency_hz(fault, rpm)
    strikes_hz = None if frequency is None else frequency * (2.0 if fault == "ball" else 1.0)  # a ball meets both races
    if strikes_hz is not None and strikes_hz * duration_s < 1.0:
        raise BearingTwinError(
            f"simulator.rpm={rpm:g}: the {fault} defect ({FAULT_FREQUENCY[fault].upper()} {frequency:.3g} Hz) is struck "
            f"{strikes_hz * duration_s:.2g} times in simulator.duration={duration_s:g} s, so the record would show no "
            f"fault; raise the speed, or the duration to at least {1.0 / strikes_hz:.3g} s"
        )
    if strikes_hz is not None and strikes_hz >= fs / 2.0:
        named = ("2x" if fault == "ball" else "") + FAULT_FREQUENCY[fault].upper()
        raise BearingTwinError(
            f"simulator.fs={fs:g} Hz cannot show the {fault} fault: the defect is struck at "
            f"{named} {strikes_hz:.1f} Hz at {rpm:g} rpm, at or above fs/2 = {fs / 2.0:g} Hz; raise simulator.fs "
            f"above {2.0 * strikes_hz:.0f} Hz or lower the speed"
        )


def _memory_bytes(solver: str, n_transient: int, n_samples: int, n_balls: int) -> int:
    """Estimated peak memory of one simulation in bytes (the factors' comment says how they were measured)."""
    n_grid = n_transient + n_samples + 1
    need = n_grid * (_BYTES_PER_GRID_SAMPLE + _BYTES_PER_GRID_SAMPLE_AND_BALL * n_balls)
    return need + (n_samples * _BYTES_PER_REFERENCE_SAMPLE if solver == "reference" else 0)


def _check_memory(simulator_cfg: Mapping, n_transient: int, n_samples: int, n_balls: int,
                  concurrent: int = 1) -> None:
    """Refuse a simulation whose arrays (``concurrent`` of them at once) would need over half the memory."""
    oversample = oversample_factor(simulator_cfg)
    grid_transient = oversample * n_transient
    grid_samples = oversample * (n_samples + (2 * ANTI_ALIAS_HALF_LENGTH if oversample > 1 else 0))
    need = concurrent * _memory_bytes(simulator_cfg["solver"], grid_transient, grid_samples, n_balls)
    memory = physical_memory_bytes()
    if memory is not None and need > memory / 2:
        fs, n_grid = float(simulator_cfg["fs"]), grid_transient + grid_samples + 1
        at_once = f" for {concurrent} simulations at once" if concurrent > 1 else ""
        finer = f", solved {oversample} times finer" if oversample > 1 else ""
        raise BearingTwinError(
            f"simulator.fs={fs:g} Hz x simulator.duration={simulator_cfg['duration']:g} s is {n_samples:,} samples "
            f"({n_grid:,} with the {n_transient / fs:.3g} s start-up transient{finer}), about {need / 1e9:.3g} GB of "
            f"memory{at_once}, more than half of this machine's {memory / 1e9:.3g} GB: lower simulator.fs"
            f"{', simulator.oversample' if oversample > 1 else ''} or simulator.duration"
        )


class _Plan(NamedTuple):
    """What :func:`simulate` settles before the heavy work: every check has passed once it exists."""

    rpm: float
    fs: float
    geometry: BearingGeometry
    effects: list[Effect]
    params: DynamicParameters
    initial_cage_angle: float
    initial_state: np.ndarray
    highest_mode_hz: float
    n_transient: int
    n_samples: int
    defect: Defect
    crossing_s: float
    oversample: int  # the solver's grid is this many times finer than fs


def _plan(fault: str, bearing_cfg: Mapping, simulator_cfg: Mapping, effects_cfg: Mapping | None,
          concurrent: int = 1) -> _Plan:
    """Check the settings and solve the cheap parts (equilibrium, linear modes, defect) of one simulation.

    ``concurrent``: simulations that will run at once, for the memory check.
    """
    check_fault(fault)
    _check_settings(simulator_cfg)
    rpm, fs = float(simulator_cfg["rpm"]), float(simulator_cfg["fs"])
    geometry = BearingGeometry.from_config(bearing_cfg)
    _check_resolves_fault(fault, geometry, rpm, fs, float(simulator_cfg["duration"]))
    effects = build_effects(effects_cfg)
    for effect in effects:  # before the solver's minutes, not after them
        effect.check_rate(fs)

    params = DynamicParameters.from_config(bearing_cfg, simulator_cfg)
    for effect in effects:
        params = effect.modify_parameters(params)

    initial_cage_angle = math.radians(simulator_cfg["initial_cage_angle_deg"])
    resting_angles = initial_cage_angle + 2.0 * math.pi * np.arange(geometry.n_balls) / geometry.n_balls
    initial_state = static_equilibrium(params, resting_angles)
    highest_mode_hz, slowest_decay = linear_modes(params, initial_state, resting_angles)
    if fs <= 2.0 * highest_mode_hz:
        raise BearingTwinError(
            f"simulator.fs={fs:g} Hz cannot resolve the contact dynamics: the bearing's highest "
            f"natural frequency is {highest_mode_hz:.0f} Hz, so fs must exceed {2.0 * highest_mode_hz:.0f} Hz"
        )
    # Effects that move the balls at t = 0 start slightly off equilibrium; the transient absorbs it. Oversampled,
    # it also holds the anti-aliasing filter's reach before the record.
    n_transient = math.ceil(simulator_cfg["settle_decades"] * math.log(10.0) / slowest_decay * fs)
    oversample = oversample_factor(simulator_cfg)
    if oversample > 1:
        n_transient = max(n_transient, ANTI_ALIAS_HALF_LENGTH)
    n_samples = _record_samples(simulator_cfg)
    _check_memory(simulator_cfg, n_transient, n_samples, geometry.n_balls, concurrent)

    load_zone_angle = math.atan2(initial_state[1] - initial_state[3], initial_state[0] - initial_state[2])
    defect_cfg = simulator_cfg["defect"]
    defect = build_defect(fault, geometry, defect_cfg, load_zone_angle)
    crossing = crossing_time_s(geometry, rpm, defect_cfg["width_mm"])
    return _Plan(rpm, fs, geometry, effects, params, initial_cage_angle, initial_state, highest_mode_hz, n_transient,
                 n_samples, defect, crossing, oversample)


def unloaded_defect_note(plan: _Plan) -> str | None:
    """A note where an outer-race defect lies outside the static load zone: the arc over which the inner race,
    displaced through the clearance by the constant forces, presses the balls at rest. No ball carries load there,
    so the defect may leave little or no mark on the record (only what dynamics, an unbalance say, bring).
    Angles as ``simulator.defect.outer_angle_deg``: from the x axis (3 o'clock) towards y (12 o'clock)."""
    if plan.defect.fault != "outer":
        return None
    centre, half_zone = _static_load_zone(plan)
    apart = abs(math.remainder(plan.defect.angle_rad - centre, 2.0 * math.pi))
    if apart <= half_zone + plan.defect.half_angle_rad:
        return None
    zone = (f"the load zone spans {math.degrees(half_zone):.0f} deg either side of {math.degrees(centre) % 360:.0f} deg"
            if half_zone > 0.0 else "no ball is pressed at rest (the constant forces do not close the clearance)")
    return (f"the outer-race defect at {math.degrees(plan.defect.angle_rad) % 360:.0f} deg lies outside the static load "
            f"zone ({zone}; 0 deg is 3 o'clock, 90 deg 12 o'clock): no ball carries load over it, so the record may "
            "show little or nothing of it")


def _static_load_zone(plan: _Plan) -> tuple[float, float]:
    """The static load zone's centre and half-width (rad, from x towards y): the arc over which the inner race,
    displaced through the clearance by the constant forces, presses the balls at rest."""
    state, clearance = plan.initial_state, plan.params.clearance_m
    shift = math.hypot(state[0] - state[2], state[1] - state[3])  # of the inner race against the outer
    centre = math.atan2(state[1] - state[3], state[0] - state[2])
    # A ball at angle a from the centre is pressed where shift*cos(a) exceeds the clearance (Harris: the half-angle
    # acos(c / shift)): a quarter circle either side at zero clearance, more under preload (a negative clearance),
    # the whole circle once the preload exceeds the shift.
    if shift == 0.0:
        return centre, math.pi if clearance < 0.0 else 0.0
    return centre, math.acos(min(max(clearance / shift, -1.0), 1.0))


def unstruck_defect_note(plan: _Plan, kinematics: Kinematics, record: slice) -> str | None:
    """A note where an inner-race or ball defect meets no ball inside the static load zone over the record (the
    kinematics' grid samples ``record``): at a low speed in a short record the defect may turn through the
    unloaded side only, and the record is then a healthy bearing's. (An outer-race defect stands still:
    :func:`unloaded_defect_note` says where it lies.) A defect is taken as met when the angle between it and a
    ball comes within its half-width plus one grid step's turn, so no passage falls between two samples."""
    defect = plan.defect
    if defect.fault not in ("inner", "ball"):
        return None
    turn, period = (("a shaft revolution", 60.0 / plan.rpm) if defect.fault == "inner"
                    else ("a cage revolution", 1.0 / plan.geometry.ftf_hz(plan.rpm)))
    centre, half_zone = _static_load_zone(plan)
    if half_zone == 0.0 or plan.n_samples / plan.fs >= period:  # no static zone, or a whole turn: the dynamics decide
        return None
    # At the record's rate, not the solver's finer grid: the reach below spans the samples between.
    record = slice(record.start, record.stop, plan.oversample)
    cage, offsets = kinematics.cage_angle_rad[record], kinematics.ball_offset_rad[record]
    ball_angles = cage[:, None] + 2.0 * math.pi * np.arange(kinematics.n_balls) / kinematics.n_balls + offsets

    def within(angles: np.ndarray, half_width: float) -> np.ndarray:
        return np.abs(np.remainder(angles + math.pi, 2.0 * math.pi) - math.pi) <= half_width

    def reach(angles: np.ndarray) -> float:  # the half-width widened by the largest turn between two samples
        return defect.half_angle_rad + float(np.max(np.abs(np.diff(angles, axis=0)), initial=0.0))

    loaded = within(ball_angles - centre, half_zone)
    if defect.fault == "inner":
        relative = ball_angles - kinematics.shaft_angle_rad[record, None] - defect.angle_rad
        met = within(relative, reach(relative)) & loaded
    else:
        spin = kinematics.ball_spin_angle_rad[record] - defect.angle_rad
        facing = within(spin, reach(spin)) | within(spin - math.pi, reach(spin))
        met = facing & loaded[:, defect.ball_index]
    if met.any():
        return None
    missed = ("no ball passes the inner-race defect inside the load zone" if defect.fault == "inner"
              else "the ball defect faces no race while its ball is inside the load zone")
    return (f"{missed} in this {plan.n_samples / plan.fs:.3g} s record at {plan.rpm:g} rpm "
            f"(the static load zone spans {math.degrees(half_zone):.0f} deg either side of "
            f"{math.degrees(centre) % 360:.0f} deg): the record is a healthy bearing's; simulator.duration of {turn} "
            f"({period:.3g} s) or more lets it through the load zone")


def sensor_name(sensor: str, sensor_angle_deg: float | None = None) -> str:
    """The sensor as a record names it: the axis (``inner_x``), or its race and direction where
    ``sensor_angle_deg`` points it between the axes (``inner race at 45 deg``, 0 along x, 90 along y)."""
    if sensor_angle_deg is None:
        return sensor
    return f"{sensor.split('_')[0]} race at {float(sensor_angle_deg) % 360.0:g} deg"


def sensor_signal(channels: np.ndarray, sensor: str, sensor_angle_deg: float | None = None) -> np.ndarray:
    """The acceleration an accelerometer on ``sensor``'s race reads, in m/s^2.

    ``channels`` is the (..., 4, n) array of race accelerations in :data:`CHANNELS` order. With
    ``sensor_angle_deg`` null the sensor reads the axis ``sensor`` names; otherwise it sits on
    the race ``sensor`` names (``inner_*`` or ``outer_*``) pointing at that angle from the
    horizontal x axis towards y (90 = vertical, the direction gravity and a belt load act in):
    it reads the projection cos(a) x + sin(a) y.
    """
    if sensor_angle_deg is None:
        return channels[..., CHANNELS.index(sensor), :].copy()
    race = sensor.split("_")[0]
    angle = math.radians(sensor_angle_deg)
    return (math.cos(angle) * channels[..., CHANNELS.index(f"{race}_x"), :]
            + math.sin(angle) * channels[..., CHANNELS.index(f"{race}_y"), :])


def simulate(fault: str, bearing_cfg: Mapping, simulator_cfg: Mapping, effects_cfg: Mapping | None = None,
             progress: bool = False) -> tuple[Recording, np.ndarray]:
    """Simulate one bearing state.

    Returns:
        recording: the sensor channel in m/s^2 after the effects' sensor path.
        channels: (4, n) accelerations in m/s^2 of the races, rows in :data:`CHANNELS` order.
    """
    bearing_cfg, simulator_cfg = plain_config(bearing_cfg, "bearing"), plain_config(simulator_cfg, "simulator")
    plan = _plan(fault, bearing_cfg, simulator_cfg, effects_cfg)
    rpm, fs, params, defect, crossing = plan.rpm, plan.fs, plan.params, plan.defect, plan.crossing_s
    highest_mode_hz, n_transient, n_samples = plan.highest_mode_hz, plan.n_transient, plan.n_samples
    rng = np.random.default_rng(np.random.SeedSequence([int(simulator_cfg["seed"]), FAULTS.index(fault)]))
    oversample = plan.oversample
    # On the solver's grid (q x fs): the record with, when oversampled, the filter's reach either side of it
    # (before it, out of the start-up transient).
    margin = ANTI_ALIAS_HALF_LENGTH if oversample > 1 else 0
    grid_fs = oversample * fs
    first, count = oversample * (n_transient - margin), oversample * (n_samples + 2 * margin)

    kinematics = rigid_kinematics(plan.geometry, rpm, grid_fs, first + count + 1, plan.initial_cage_angle)
    for effect in plan.effects:
        kinematics = effect.modify_kinematics(kinematics, rng)

    meta = {"transient_s": n_transient / fs, "contact_stiffness_n_per_m1_5": params.contact_stiffness_n_per_m1_5,
            "highest_mode_hz": highest_mode_hz, "defect_depth_m": defect.depth_m, "solver": simulator_cfg["solver"],
            "oversample": oversample}
    record = slice(first + oversample * margin, first + oversample * (margin + n_samples))
    notes = [note for note in (unloaded_defect_note(plan), unstruck_defect_note(plan, kinematics, record)) if note]
    if notes:
        meta["notes"] = notes
    if simulator_cfg["solver"] == "fast":
        settings = simulator_cfg["fast"]
        resolution = (grid_fs, highest_mode_hz, crossing, settings["steps_per_period"], settings["steps_per_defect"])
        substeps, per_step = fast.substeps_per_sample(*resolution), fast.samples_per_step(*resolution)
        meta["substeps"], meta["samples_per_step"] = substeps, per_step
        with tqdm(total=first + count, unit="sample", unit_scale=True, desc=f"simulate {fault}",
                  disable=not progress, leave=False) as bar:
            channels = fast.integrate(params, kinematics, defect.as_array(), plan.initial_state, first, count,
                                      substeps, progress=bar, per_step=per_step)
    else:
        settings = simulator_cfg["reference"]
        channels = reference.integrate(params, kinematics, defect.as_array(), plan.initial_state, first, count,
                                       rtol=settings["rtol"], atol=settings["atol"],
                                       max_step_s=crossing / settings["steps_per_defect"])
    if oversample > 1:
        channels = scipy.signal.resample_poly(channels, 1, oversample, axis=-1)[:, margin:margin + n_samples]

    signal = sensor_signal(channels, simulator_cfg["sensor"], simulator_cfg.get("sensor_angle_deg"))
    for effect in plan.effects:
        signal = effect.modify_signal(signal, fs, rng, rpm / 60.0)
    recording = Recording(signal=signal, fs=fs, rpm=rpm, fault=fault, source=f"simulated:{bearing_cfg.get('name', '')}",
                          channel=sensor_name(simulator_cfg["sensor"], simulator_cfg.get("sensor_angle_deg")),
                          unit="m/s^2", meta=meta)
    return recording, channels


def simulate_at_speeds(faults: Sequence[str], rpms: Sequence[float], bearing_cfg: Mapping, simulator_cfg: Mapping,
                       effects_cfg: Mapping | None = None, variant: int | None = None) -> np.ndarray:
    """Sensor signals ``(len(faults) * len(rpms), n)`` in m/s^2, fault-major: each state at each speed (rev/min).

    Every record gets its own seed for the twin's random effects, derived from ``simulator.seed`` (and ``variant``,
    the index of a combination of settings, if any), the state and the speed's place, so two operating points or two
    variants do not share one noise realization.
    """
    seed = whole_number("simulator.seed", simulator_cfg["seed"], minimum=0)
    signals = []
    for fault in faults:
        for index, rpm in enumerate(rpms):
            record_seed = derived_seed(seed, *([] if variant is None else [variant]), FAULTS.index(fault), index)
            recording, _ = simulate(fault, bearing_cfg, {**simulator_cfg, "rpm": float(rpm), "seed": record_seed},
                                    effects_cfg)
            signals.append(recording.signal)
    return np.stack(signals)


def simulate_many(faults: Sequence[str], bearing_cfg: Mapping, simulator_cfg: Mapping,
                  effects_cfg: Mapping | None = None, n_jobs: int = 1) -> list[tuple[Recording, np.ndarray]]:
    """:func:`simulate` for several bearing states, in parallel processes when ``n_jobs`` > 1."""
    bearing_cfg, simulator_cfg = plain_config(bearing_cfg, "bearing"), plain_config(simulator_cfg, "simulator")
    effects_cfg = plain_config(effects_cfg, "effects")
    concurrent = max(1, min(len(faults), joblib.effective_n_jobs(n_jobs)))
    for fault in faults:  # every state's checks before any simulation starts: the cheap parts, run again in the jobs
        _plan(fault, bearing_cfg, simulator_cfg, effects_cfg, concurrent)
    return joblib.Parallel(n_jobs=n_jobs)(
        joblib.delayed(simulate)(fault, bearing_cfg, simulator_cfg, effects_cfg) for fault in faults
    )
