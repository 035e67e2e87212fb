"""The twin at a measurement's operating point, as a function of its free parameters and effects.

Calibration evaluates the simulator hundreds of times with small changes: base
parameters addressed by dotted config keys (``simulator.defect.depth_mm``,
``bearing.inner_damping_ns_per_m``) and an ordered set of effects. The four race
accelerations of the last simulation are cached: where the sensor sits
(``simulator.sensor``, ``simulator.sensor_angle_deg``) and the effects that act on the
sensor path only do not change them, so moving the sensor or trying a resonance or
noise candidate costs a projection and a filter, not a simulation.
"""

from __future__ import annotations

import copy
import functools
import json
import threading
from pathlib import Path
from typing import Mapping

import numpy as np
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR, compose_config, plain_config, search_path_override
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import (acting_before, build_effects, effect_class, in_signal_order,
                                         registered_effects, sensor_only)
from bearingtwin.physics.geometry import FAULTS, check_fault
from bearingtwin.physics.simulator import sensor_signal, simulate


def effect_defaults(name: str) -> dict:
    """The nominal parameters of effect ``name`` from ``conf/effects/<name>.yaml``: the checkout's, or for an effect
    of one's own package (its ``bearingtwin.effects`` entry point) the one in a folder on ``hydra.searchpath``."""
    if name not in registered_effects():
        raise BearingTwinError(f"unknown effect {name!r}; registered: {', '.join(registered_effects())}")
    path = Path(CONF_DIR) / "effects" / f"{name}.yaml"
    if path.is_file():
        content = OmegaConf.to_container(OmegaConf.load(path), resolve=True)
    else:  # an effect of one's own package
        content = _searched_effect(name, tuple(search_path_override()))
    if name not in content:
        raise BearingTwinError(f"conf/effects/{name}.yaml must nest the parameters under '{name}:'")
    return dict(content[name] or {})


_COMPOSING = threading.Lock()
"""Hydra's global state is one per process: the ranking's threads compose an effect's config one at a time."""


@functools.lru_cache(maxsize=None)
def _searched_effect(name: str, search_path: tuple[str, ...]) -> dict:
    """The effects config ``effects=[name]`` composes to with ``search_path`` (the running command's; composed once)."""
    from hydra.errors import HydraException

    try:
        with _COMPOSING:
            composed = compose_config("twin", [f"effects=[{name}]", *search_path])
    except HydraException as error:
        raise BearingTwinError(f"effect {name!r}: no conf/effects/{name}.yaml in the checkout, and on hydra.searchpath "
                               f"{str(error).splitlines()[0]}") from None
    return OmegaConf.to_container(composed.effects, resolve=True)


def check_calibratable(name: str) -> None:
    """Refuse an effect (by name) that declares no ``search_space``: the twin has nothing of it to fit."""
    if not getattr(effect_class(name), "search_space", None):
        raise BearingTwinError(f"effect {name!r} declares no search_space, so it cannot be calibrated")


def effect_search_space(name: str, fs: float) -> dict[str, tuple[float, float, bool]]:
    """The box each of the effect's fitted parameters is searched in on a record sampled at ``fs`` (Hz) (its class's
    ``search_space_at``: a mode's natural frequency reaches as high as the rate lets a record show it)."""
    check_calibratable(name)
    return effect_class(name).search_space_at(fs)


SENSOR_KEYS = ("simulator.sensor", "simulator.sensor_angle_deg")
"""Base parameters that select what the sensor reads of a simulation, not what is simulated."""


class TwinModel:
    """``signal(base, effects)``: the twin's sensor signal at the operating point of a measurement.

    Args:
        fault: bearing state to simulate.
        bearing_cfg, simulator_cfg: the composed config groups; ``simulator_cfg`` must already
            carry the measurement's rpm and fs and the duration to simulate.
        seed: seeds every random effect; fixed across calls (common random numbers).
    """

    def __init__(self, fault: str, bearing_cfg: Mapping, simulator_cfg: Mapping, seed: int):
        self.fault = check_fault(fault)
        config = OmegaConf.create({
            "bearing": OmegaConf.to_container(OmegaConf.create(dict(bearing_cfg)), resolve=True),
            "simulator": OmegaConf.to_container(OmegaConf.create(dict(simulator_cfg)), resolve=True),
        })
        config.simulator.seed = int(seed)
        # Plain dicts, cheap to copy for each simulation; a missing value is named here, before any is run.
        self.config = {name: plain_config(config[name], name) for name in ("bearing", "simulator")}
        self.seed = int(seed)
        self.fs = float(self.config["simulator"]["fs"])
        self._cache: tuple[str, np.ndarray] | None = None
        self.n_simulations = 0

    def fresh(self) -> "TwinModel":
        """The same twin with an empty cache, for another thread (a cache is not shared)."""
        return TwinModel(self.fault, self.config["bearing"], self.config["simulator"], self.seed)

    def value(self, key: str, group: str = "calibration.base"):
        """The configured value of a dotted ``bearing.*`` / ``simulator.*`` key (a base parameter); errors name
        the key as an entry of ``group``, the setting it came from."""
        node = self.config
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                raise BearingTwinError(f"{group}.{key}: no such bearing.* or simulator.* config key "
                                       "(a key names a value inside nested mappings, no list index)")
            node = node[part]
        return node

    def _configured(self, base: Mapping) -> dict:
        """Plain copies of the bearing and simulator configs with ``base`` set (a copy of plain dicts
        costs a hundredth of an OmegaConf deep copy, and the ranking makes hundreds)."""
        cfg = copy.deepcopy(self.config)
        for key, value in base.items():
            self.value(key)
            *parents, leaf = key.split(".")
            node = cfg
            for part in parents:
                node = node[part]
            node[leaf] = float(value)  # the sensor keys select what is read of a simulation: never set here
        return cfg

    def level_under(self, name: str, base: Mapping, effects: Mapping[str, Mapping]) -> float:
        """RMS (m/s^2) of the signal that effect ``name`` of ``effects`` acts on in this twin with base parameters
        ``base``: the level a ratio it was fitted as refers to (``noise.snr_db``)."""
        return float(np.sqrt(np.mean(self.signal(base, acting_before(name, effects)) ** 2)))

    def signal(self, base: Mapping | None = None, effects: Mapping[str, Mapping] | None = None) -> np.ndarray:
        """The sensor signal (m/s^2) with base parameters ``base`` and ``effects`` in the order they act."""
        base, effects = dict(base or {}), in_signal_order(dict(effects or {}))
        instances = build_effects(effects)
        split = len(instances)
        while split > 0 and sensor_only(instances[split - 1]):
            split -= 1
        head = dict(list(effects.items())[:split])
        simulated = {k: v for k, v in base.items() if k not in SENSOR_KEYS}
        key = json.dumps([sorted(simulated.items()), head], sort_keys=True, default=float)
        if self._cache is None or self._cache[0] != key:
            cfg = self._configured(simulated)
            _, channels = simulate(self.fault, cfg["bearing"], cfg["simulator"], head)
            self.n_simulations += 1
            self._cache = (key, channels)
        sensor = {"simulator.sensor": self.value("simulator.sensor"),
                  "simulator.sensor_angle_deg": self.config["simulator"].get("sensor_angle_deg"),
                  **{k: v for k, v in base.items() if k in SENSOR_KEYS}}
        signal = sensor_signal(self._cache[1], sensor["simulator.sensor"], sensor["simulator.sensor_angle_deg"])
        # Every effect's sensor path runs here, on the projected channel, with one seeded stream.
        rng = np.random.default_rng(np.random.SeedSequence([self.seed, FAULTS.index(self.fault), 1]))
        shaft_hz = float(self.config["simulator"]["rpm"]) / 60.0
        for effect in instances:
            signal = effect.modify_signal(signal, self.fs, rng, shaft_hz)
        return signal
