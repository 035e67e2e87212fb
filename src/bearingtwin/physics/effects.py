"""The extension point for physical effects the paper's ideal model leaves out.

An effect is a small class with physically meaningful parameters that acts at up to
three stages of a simulation, each a no-op unless overridden:

1. ``modify_parameters(params) -> params``: the :class:`DynamicParameters` (stiffness,
   damping, clearance, loads), e.g. a lubricant film in series with the contacts;
2. ``modify_kinematics(kinematics, rng) -> kinematics``: the sampled angle series the
   solvers read (:class:`Kinematics`), e.g. random ball slip, shaft-speed fluctuation;
3. ``modify_signal(signal, fs, rng) -> signal``: the sensor path, applied to the 1-D
   sensor acceleration (m/s^2) after the bearing, e.g. a transmission resonance, noise.

Effects run in configuration order at every stage. Each registers under its ``name``
with :func:`register_effect`; ``conf/effects/<name>.yaml`` nests the constructor
arguments under ``<name>:``, and :func:`build_effects` turns the composed ``effects``
mapping into instances. The core model knows no effect by name.
"""

from __future__ import annotations

import importlib
from typing import ClassVar, Mapping

import numpy as np
from omegaconf import DictConfig, OmegaConf

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.dynamics import DynamicParameters
from bearingtwin.physics.kinematics import Kinematics

LIBRARY_MODULE = "bearingtwin.physics.effect_library"
"""Imported by :func:`build_effects` so that the effect library's classes are registered."""

_REGISTRY: dict[str, type["Effect"]] = {}


class Effect:
    """Base class: override any of the three stages; the rest leave the simulation unchanged."""

    name: ClassVar[str] = ""

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return params

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        return kinematics

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator) -> np.ndarray:
        return signal


def register_effect(cls: type[Effect]) -> type[Effect]:
    """Class decorator: make ``cls`` available under ``cls.name`` in the ``effects`` config."""
    if not (isinstance(cls, type) and issubclass(cls, Effect)) or not cls.name:
        raise BearingTwinError(f"{cls!r} is not an Effect subclass with a non-empty name")
    known = _REGISTRY.get(cls.name)
    if known is not None and known.__qualname__ != cls.__qualname__:
        raise BearingTwinError(f"effect name {cls.name!r} is already taken by {known.__module__}.{known.__qualname__}")
    _REGISTRY[cls.name] = cls
    return cls


def registered_effects() -> tuple[str, ...]:
    """Names usable in ``effects=[...]``, after loading the effect library."""
    _load_library()
    return tuple(sorted(_REGISTRY))


def build_effects(effects_cfg: Mapping | None) -> list[Effect]:
    """Instances of the configured effects, in order; ``effects_cfg`` maps name -> constructor args."""
    if not effects_cfg:
        return []
    if isinstance(effects_cfg, DictConfig):
        effects_cfg = OmegaConf.to_container(effects_cfg, resolve=True)
    if not isinstance(effects_cfg, Mapping):
        raise BearingTwinError(f"effects must map effect names to their parameters, got {effects_cfg!r}")
    _load_library()
    effects = []
    for name, arguments in effects_cfg.items():
        if name not in _REGISTRY:
            raise BearingTwinError(f"effects.{name}: unknown effect; registered: {', '.join(sorted(_REGISTRY)) or 'none'}")
        try:
            effects.append(_REGISTRY[name](**(arguments or {})))
        except TypeError as error:
            raise BearingTwinError(f"effects.{name}: bad parameters {arguments!r} ({error})") from None
    return effects


def _load_library() -> None:
    try:
        importlib.import_module(LIBRARY_MODULE)
    except ModuleNotFoundError as error:
        if error.name != LIBRARY_MODULE:
            raise
