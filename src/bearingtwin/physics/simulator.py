"""The digital twin: bearing + simulator config (+ effects) in, vibration records out.

One simulation: build the dynamic parameters (effects may change them), the rigid
rolling kinematics on the output grid (effects may perturb them), solve the static
equilibrium so the bearing starts at rest under its load, integrate through a
start-up transient long enough for the slowest linearized mode to decay by
``simulator.settle_decades`` decades, and keep ``simulator.duration`` seconds of the
accelerations of the inner and outer race in x and y. The sensor channel
(``simulator.sensor``) then passes through the effects' sensor path.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import joblib
import numpy as np
from tqdm.auto import tqdm

from bearingtwin.config import plain_config
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics import solvers
from bearingtwin.physics.defects import build_defect, crossing_time_s
from bearingtwin.physics.dynamics import DynamicParameters, linear_modes, static_equilibrium
from bearingtwin.physics.effects import build_effects
from bearingtwin.physics.geometry import FAULTS, BearingGeometry, check_fault
from bearingtwin.physics.kinematics import rigid_kinematics
from bearingtwin.physics.solvers import fast, reference

CHANNELS = ("inner_x", "inner_y", "outer_x", "outer_y")
"""Rows of the (4, n) acceleration array, and the values ``simulator.sensor`` accepts."""


def _check_settings(simulator_cfg: Mapping) -> None:
    for name in ("rpm", "fs", "duration"):
        value = simulator_cfg[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise BearingTwinError(f"simulator.{name} must be a positive, finite number, got {value!r}")
    if simulator_cfg["solver"] not in solvers.SOLVERS:
        raise BearingTwinError(f"simulator.solver={simulator_cfg['solver']!r}: choose one of {', '.join(solvers.SOLVERS)}")
    if simulator_cfg["sensor"] not in CHANNELS:
        raise BearingTwinError(f"simulator.sensor={simulator_cfg['sensor']!r}: choose one of {', '.join(CHANNELS)}")
    angle = simulator_cfg.get("sensor_angle_deg")
    if angle is not None and (isinstance(angle, bool) or not isinstance(angle, (int, float)) or not math.isfinite(angle)):
        raise BearingTwinError(f"simulator.sensor_angle_deg must be null or a finite angle in degrees, got {angle!r}")
    if not simulator_cfg["settle_decades"] > 0:
        raise BearingTwinError(f"simulator.settle_decades must be positive, got {simulator_cfg['settle_decades']}")


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
    check_fault(fault)
    bearing_cfg, simulator_cfg = plain_config(bearing_cfg), plain_config(simulator_cfg)
    _check_settings(simulator_cfg)
    rpm, fs = float(simulator_cfg["rpm"]), float(simulator_cfg["fs"])
    geometry = BearingGeometry.from_config(bearing_cfg)
    effects = build_effects(effects_cfg)
    rng = np.random.default_rng(np.random.SeedSequence([int(simulator_cfg["seed"]), FAULTS.index(fault)]))

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
    # Effects that move the balls at t = 0 start slightly off equilibrium; the transient absorbs it.
    n_transient = math.ceil(simulator_cfg["settle_decades"] * math.log(10.0) / slowest_decay * fs)
    n_samples = round(simulator_cfg["duration"] * fs)
    kinematics = rigid_kinematics(geometry, rpm, fs, n_transient + n_samples + 1, initial_cage_angle)
    for effect in effects:
        kinematics = effect.modify_kinematics(kinematics, rng)

    load_zone_angle = math.atan2(initial_state[1] - initial_state[3], initial_state[0] - initial_state[2])
    defect_cfg = simulator_cfg["defect"]
    defect = build_defect(fault, geometry, defect_cfg, load_zone_angle)
    crossing = crossing_time_s(geometry, rpm, defect_cfg["width_mm"])

    meta = {"transient_s": n_transient / fs, "contact_stiffness_n_per_m1_5": params.contact_stiffness_n_per_m1_5,
            "highest_mode_hz": highest_mode_hz, "defect_depth_m": defect.depth_m, "solver": simulator_cfg["solver"]}
    if simulator_cfg["solver"] == "fast":
        settings = simulator_cfg["fast"]
        resolution = (fs, highest_mode_hz, crossing, settings["steps_per_period"], settings["steps_per_defect"])
        substeps, per_step = fast.substeps_per_sample(*resolution), fast.samples_per_step(*resolution)
        meta["substeps"], meta["samples_per_step"] = substeps, per_step
        with tqdm(total=n_transient + n_samples, unit="sample", unit_scale=True, desc=f"simulate {fault}",
                  disable=not progress, leave=False) as bar:
            channels = fast.integrate(params, kinematics, defect.as_array(), initial_state, n_transient, n_samples,
                                      substeps, progress=bar, per_step=per_step)
    else:
        settings = simulator_cfg["reference"]
        channels = reference.integrate(params, kinematics, defect.as_array(), initial_state, n_transient, n_samples,
                                       rtol=settings["rtol"], atol=settings["atol"],
                                       max_step_s=crossing / settings["steps_per_defect"])

    signal = sensor_signal(channels, simulator_cfg["sensor"], simulator_cfg.get("sensor_angle_deg"))
    for effect in effects:
        signal = effect.modify_signal(signal, fs, rng, rpm / 60.0)
    recording = Recording(signal=signal, fs=fs, rpm=rpm, fault=fault, source=f"simulated:{bearing_cfg.get('name', '')}",
                          channel=simulator_cfg["sensor"], unit="m/s^2", meta=meta)
    return recording, channels


def simulate_many(faults: Sequence[str], bearing_cfg: Mapping, simulator_cfg: Mapping,
                  effects_cfg: Mapping | None = None, n_jobs: int = 1) -> list[tuple[Recording, np.ndarray]]:
    """:func:`simulate` for several bearing states, in parallel processes when ``n_jobs`` > 1."""
    bearing_cfg, simulator_cfg, effects_cfg = plain_config(bearing_cfg), plain_config(simulator_cfg), plain_config(effects_cfg)
    for fault in faults:
        check_fault(fault)
    return joblib.Parallel(n_jobs=n_jobs)(
        joblib.delayed(simulate)(fault, bearing_cfg, simulator_cfg, effects_cfg) for fault in faults
    )
