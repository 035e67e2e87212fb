"""The extension point for physical effects the paper's ideal model leaves out.

An effect is a small class with physically meaningful parameters that acts at up to
three stages of a simulation, each a no-op unless overridden:

1. ``modify_parameters(params) -> params``: the :class:`DynamicParameters` (stiffness,
   damping, clearance, loads), e.g. a lubricant film in series with the contacts;
2. ``modify_kinematics(kinematics, rng) -> kinematics``: the sampled angle series the
   solvers read (:class:`Kinematics`), e.g. random ball slip, shaft-speed fluctuation;
3. ``modify_signal(signal, fs, rng, shaft_hz) -> signal``: the sensor path, applied to the
   1-D sensor acceleration (m/s^2) after the bearing, e.g. a transmission resonance, noise,
   lines at multiples of the shaft rate ``shaft_hz`` (the nominal ``rpm / 60``, in Hz).

Effects run in configuration order at every stage, except one that acts on the signal as
recorded (``records_last``: a converter's range): it runs after all others, wherever it is
listed, as a saturation clips whatever reaches the recorder. Each registers under its ``name``
with :func:`register_effect`; ``conf/effects/<name>.yaml`` nests the constructor
arguments under ``<name>:``, and :func:`build_effects` turns the composed ``effects``
mapping into instances. The core model knows no effect by name.

Four optional class-level hooks serve the ranking of :mod:`bearingtwin.twin.rank`, not
the simulation:

- ``requires``: names of effects that must already be in the twin before this one is
  offered as a candidate. A second structural mode, say, is told apart from the first
  only once the first is in the twin; offered alone, ``resonance`` explains it as well.
- ``bearing_states``: the bearing states whose records can tell the effect, where not every
  state's can (empty: every state). It is offered as a candidate on those records only; a
  twin given it as known (``effects=``, a reference's) keeps it on any record.
- ``initial_guess(measured, twin, fs, shaft_hz)``: constructor parameters read off the
  data, to be the first trial of the effect's calibration. An effect whose signature is a
  few narrow lines needs it: a line's frequency is a needle that a search over a box of
  frequencies does not find in a few trials, while the measured spectrum shows it.
- ``signature_views``: the comparison views (:data:`bearingtwin.twin.compare.VIEWS`) in
  which the effect leaves its mark. The ranking claims the effect only if the twin gets closer
  to the measurement there, not merely somewhere: a set of tones lowers the kurtosis any added
  energy lowers, and that alone is no sign of tones (their lines are). Empty: every view.
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
from typing import ClassVar, Mapping

import numpy as np
from omegaconf import DictConfig, OmegaConf

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.dynamics import DynamicParameters
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.physics.kinematics import Kinematics

LIBRARY_MODULE = "bearingtwin.physics.effect_library"
"""Imported by :func:`build_effects` so that the effect library's classes are registered."""

PLUGIN_GROUP = "bearingtwin.effects"
"""The entry-point group of effects kept in a package of one's own: each entry names a module whose
``@register_effect`` classes are registered when it is imported (``[project.entry-points."bearingtwin.effects"]``
in that package's pyproject.toml), in every process that reads effects, a sweep's workers too."""

_REGISTRY: dict[str, type["Effect"]] = {}


class Effect:
    """Base class: override any of the three stages; the rest leave the simulation unchanged.

    An effect that overrides only ``modify_signal`` is *sensor-only*: it commutes with the
    solver, so the twin re-runs it on a cached simulation (a filter, not a simulation).

    Class attributes:
        name: the registry and config name.
        requires: effects the ranking needs in the twin before it offers this one (see the
            module docstring); a ranking notion, not checked when effects are built, so a
            simulation may use the effect alone.
        bearing_states: the states whose records the ranking offers it on (empty: every state);
            a ranking notion too.
        signature_views: the comparison views its signature shows in (module docstring).
        records_last: the effect acts on the signal as recorded, so it runs after every other
            effect (:func:`in_signal_order`).
    """

    name: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()
    bearing_states: ClassVar[tuple[str, ...]] = ()
    signature_views: ClassVar[tuple[str, ...]] = ()
    records_last: ClassVar[bool] = False

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict | None:
        """Constructor parameters estimated from a measurement, or None to start from the config.

        Args:
            measured: the measured sensor signal (any unit).
            twin: the current twin's signal at the same ``fs`` (Hz), scaled by the sensor gain
                that matches it to ``measured``, without this effect.
            fs: sampling rate in Hz; shaft_hz: shaft rate in Hz (``rpm / 60``).

        Returns:
            A JSON-serialisable subset of the constructor's parameters (plain floats and lists);
            the others keep their configured values. Levels in dB are relative to the RMS of
            ``twin``, which is the signal the effect acts on when the ranking appends it.
        """
        return None

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return params

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        return kinematics

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        """The sensor signal sampled at ``fs`` (Hz) with a shaft turning at ``shaft_hz`` (Hz)."""
        return signal

    def check_rate(self, fs: float) -> None:
        """Refuse a sampling rate ``fs`` (Hz) the effect cannot act at (a mode above Nyquist), before the solver
        runs: ``modify_signal`` would refuse it only after the simulation."""

    @classmethod
    def search_space_at(cls, fs: float) -> dict[str, tuple[float, float, bool]]:
        """The box (low, high, log scale) each fitted parameter is searched in on a record sampled at ``fs`` (Hz):
        the class's ``search_space``, which most effects declare whatever the rate; empty when it declares none."""
        return dict(getattr(cls, "search_space", {}))


def sensor_only(effect: "Effect | type[Effect]") -> bool:
    """Whether an effect (instance or class) acts on the sensor path alone: it overrides neither
    ``modify_parameters`` nor ``modify_kinematics``, so it runs after the solver whatever its place in the list."""
    cls = effect if isinstance(effect, type) else type(effect)
    return cls.modify_parameters is Effect.modify_parameters and cls.modify_kinematics is Effect.modify_kinematics


def register_effect(cls: type[Effect]) -> type[Effect]:
    """Class decorator: make ``cls`` available under ``cls.name`` in the ``effects`` config."""
    if not (isinstance(cls, type) and issubclass(cls, Effect)) or not cls.name:
        raise BearingTwinError(f"{cls!r} is not an Effect subclass with a non-empty name")
    if not isinstance(cls.bearing_states, tuple) or not set(cls.bearing_states) <= set(FAULTS):
        raise BearingTwinError(f"effect {cls.name!r}: bearing_states must be a tuple of bearing states "
                               f"({', '.join(FAULTS)}), got {cls.bearing_states!r}")
    known = _REGISTRY.get(cls.name)
    if known is not None and known.__qualname__ != cls.__qualname__:
        raise BearingTwinError(f"effect name {cls.name!r} is already taken by {known.__module__}.{known.__qualname__}")
    _REGISTRY[cls.name] = cls
    return cls


def registered_effects() -> tuple[str, ...]:
    """Names usable in ``effects=[...]``, after loading the effect library."""
    _load_library()
    return tuple(sorted(_REGISTRY))


def effect_class(name: str) -> type[Effect]:
    """The class registered as ``name`` (its ``search_space``, ``signature_views``, ``requires``, ...)."""
    _load_library()
    if name not in _REGISTRY:
        raise BearingTwinError(f"unknown effect {name!r}; {_registered_words()}")
    return _REGISTRY[name]


def in_signal_order(effects_cfg: Mapping) -> dict:
    """The configured effects (name -> constructor args) in the order they act: as listed, those that act on
    the signal as recorded (``records_last``) moved to the end. An unknown name is left in place for
    :func:`build_effects` to name."""
    _load_library()

    def records_last(name) -> bool:
        return name in _REGISTRY and _REGISTRY[name].records_last

    return dict(sorted(effects_cfg.items(), key=lambda item: records_last(item[0])))  # a stable sort


def acting_before(name: str, effects_cfg: Mapping) -> dict:
    """The effects of ``effects_cfg`` that shape the signal effect ``name`` acts on: every one acting inside the
    simulation, and those on the sensor path before it in signal order (a resonance found after a noise filters
    the noise, not the signal the noise's level refers to)."""
    ordered = list(in_signal_order(effects_cfg))
    after = ordered[ordered.index(name) + 1:]
    return {other: params for other, params in effects_cfg.items()
            if other != name and not (other in after and sensor_only(effect_class(other)))}


def order_identity(effects_cfg: Mapping | None) -> dict:
    """What a cache key of simulations needs beside the effects mapping, which a content hash reads in any order:
    the order they act in (:func:`in_signal_order`), where there are several (one effect alone, or none, keeps
    the key it had before the order counted)."""
    effects = dict(effects_cfg or {})
    return {"effect_order": list(in_signal_order(effects))} if len(effects) > 1 else {}


def build_effects(effects_cfg: Mapping | None) -> list[Effect]:
    """Instances of the configured effects, in the order they act (:func:`in_signal_order`); ``effects_cfg``
    maps name -> constructor args."""
    if not effects_cfg:
        return []
    if isinstance(effects_cfg, DictConfig):
        effects_cfg = OmegaConf.to_container(effects_cfg, resolve=True)
    if not isinstance(effects_cfg, Mapping):
        raise BearingTwinError(f"effects must map effect names to their parameters, got {effects_cfg!r}")
    effects = []
    for name, arguments in in_signal_order(effects_cfg).items():
        if name not in _REGISTRY:
            raise BearingTwinError(f"effects.{name}: unknown effect; {_registered_words()}")
        try:
            effects.append(_REGISTRY[name](**(arguments or {})))
        except BearingTwinError as error:  # a constructor's own check names the parameter, in its block
            said = str(error)
            raise BearingTwinError(f"effects.{said}" if said.startswith(f"{name}.") else f"effects.{name}: {said}") from None
        except (TypeError, ValueError) as error:  # a missing or unknown parameter, a list where a number belongs
            raise BearingTwinError(f"effects.{name}: bad parameters {arguments!r} ({error})") from None
    return effects


def _registered_words() -> str:
    return (f"registered: {', '.join(sorted(_REGISTRY)) or 'none'} (an effect of your own is registered through "
            f"the '{PLUGIN_GROUP}' entry points of its package: docs/guide.md, Adding an effect)")


@functools.cache
def _load_library() -> None:
    """Import the effect library and the modules of the :data:`PLUGIN_GROUP` entry points, once per process."""
    try:
        importlib.import_module(LIBRARY_MODULE)
    except ModuleNotFoundError as error:
        if error.name != LIBRARY_MODULE:
            raise
    for entry in importlib.metadata.entry_points(group=PLUGIN_GROUP):
        try:
            entry.load()
        except Exception as error:  # a plugin's own bug: named, not a traceback from inside the effects' lookup
            raise BearingTwinError(f"the effect module {entry.value} ('{PLUGIN_GROUP}' entry point {entry.name}) "
                                   f"fails to import: {type(error).__name__}: {error}") from None
