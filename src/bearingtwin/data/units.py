"""Acceleration units a record may state, and conversion between them.

Records come in m/s^2 (the twin, many loggers), in g (CWRU, most accelerometer data sheets) or in a thousandth or
a millionth of either (mg, µg, mm/s^2; cm/s^2, the galileo): the same vibration differs by a constant factor
between any two of them (standard gravity, ``scipy.constants.g``, is 9.80665 m/s^2 per g), which every
amplitude-dependent feature sees. A unit of another quantity (a voltage, a velocity, a displacement) is no factor
away from an acceleration: a voltage takes the sensor's sensitivity, a velocity a differentiation
(:func:`quantity_of` names it).
"""

from __future__ import annotations

import re

import numpy as np
import scipy.constants

from bearingtwin.errors import BearingTwinError

METRES_PER_S2 = {"m/s^2": 1.0, "mm/s^2": scipy.constants.milli, "cm/s^2": scipy.constants.centi,
                 "in/s^2": scipy.constants.inch, "ft/s^2": scipy.constants.foot,
                 "g": scipy.constants.g, "mg": scipy.constants.milli * scipy.constants.g,
                 "µg": scipy.constants.micro * scipy.constants.g}
"""Each acceleration unit's value in m/s^2, by the unit's canonical spelling."""

_PER_SECOND_SQUARED = ("/s^2", "/s2", "/s**2", "/s²", "/s/s", " s^-2", " s-2", " s⁻²", "s^-2", "s-2", "s⁻²",
                       "·s^-2", "·s-2", "·s⁻²", ".s^-2", ".s-2", ".s⁻²", "s2", "ps2")
"""How "per second squared" is written after a length (``m/s²``, ``m s^-2``; in a column's name ``acc_ms2``,
``acc_mps2``)."""
_SPELLINGS = {**{length + per: f"{length}/s^2" for length in ("m", "mm", "cm", "in", "ft") for per in _PER_SECOND_SQUARED},
              "gal": "cm/s^2", "g": "g", "g's": "g", "gn": "g", "g0": "g", "mg": "mg", "µg": "µg", "μg": "µg", "ug": "µg"}

INTEGRATED_QUANTITIES = ("a velocity", "a displacement")
"""Quantities an acceleration integrated once or twice gives: their spectrum is the acceleration's tilted (each line
divided by its frequency, once or twice), which no gain undoes, so a model or a twin free of scale is not free of them."""

_OTHER_QUANTITIES = {"v": "a voltage", "mv": "a voltage", "mm/s": "a velocity", "m/s": "a velocity", "mms": "a velocity",
                     "in/s": "a velocity", "ips": "a velocity", "um": "a displacement", "µm": "a displacement",
                     "μm": "a displacement", "mil": "a displacement", "pa": "a pressure", "rpm": "a speed",
                     "hz": "a frequency", "s": "a time", "ms": "a time"}
"""Units of other quantities than acceleration a file may state (lower case), and what each measures. Single
letters that label as often as they measure (``Sensor (A)``, ``(N)``) are left out; ``s`` stays, a time column's."""


QUANTITY_WORDS = {"velocity": "a velocity", "vel": "a velocity", "displacement": "a displacement",
                  "disp": "a displacement", "displ": "a displacement"}
"""Words a channel's name may call an integrated quantity by where it states no unit (``Velocity``, ``vel_x``): such a
record must not pass for an acceleration in the model's unit."""

_AMPLITUDE_QUALIFIER = re.compile(r"\s+(?:rms|pk|peak|0-pk|0-p|pk-pk|p-p|pp)$")
"""A detector's word after a unit (``mm/s RMS``, ``g pk``): of how a meter reads a level, not of the unit."""


def unit_key(unit: str) -> str:
    """A unit as written, compared: lower case, single spaces, none around ``/`` and ``^``, ``sec`` as ``s``, a
    detector's word after it left out (``m / s^2``, ``m/s ^2``, ``M/sec²`` and ``m/s² RMS`` are one unit)."""
    key = re.sub(r"\s*([/^])\s*", r"\1", " ".join(str(unit).split()).lower())
    return _AMPLITUDE_QUALIFIER.sub("", re.sub(r"/sec(?=[\^²2]|$)", "/s", key))


def quantity_word(name: str) -> str:
    """The word of a channel's ``name`` that calls it an integrated quantity (:data:`QUANTITY_WORDS`: ``Velocity``,
    ``vel`` in ``vel_x``), as written; "" where none does (``level``, ``travel``: a word's own letters are no word)."""
    return next((word for word in re.split(r"[^A-Za-z]+", name) if word.lower() in QUANTITY_WORDS), "")


def acceleration_unit(unit: str) -> str | None:
    """The canonical spelling (a key of :data:`METRES_PER_S2`) of an acceleration unit a file states (``G``,
    ``m/s2``, ``mm/s²``, ``Gal`` and other spellings read too); None for any other unit (``V``, ``mm/s``) or none."""
    return _SPELLINGS.get(unit_key(unit))


def same_unit(a: str, b: str) -> bool:
    """Whether two units as written are one (:func:`unit_key`), or two spellings of one acceleration unit (``m/s2``,
    ``m/s^2``)."""
    return unit_key(a) == unit_key(b) or acceleration_unit(a) is not None and acceleration_unit(a) == acceleration_unit(b)


def quantity_of(unit: str) -> str | None:
    """What ``unit`` measures: "an acceleration" for a unit :func:`acceleration_unit` reads, another quantity for a
    unit of one (``V``: "a voltage", ``mm/s``: "a velocity", ``µm``: "a displacement"), None for text that is no
    unit known here."""
    if acceleration_unit(unit):
        return "an acceleration"
    return _OTHER_QUANTITIES.get(unit_key(unit)) or QUANTITY_WORDS.get(unit_key(unit))


def acceleration_factor(from_unit: str, to_unit: str) -> float:
    """What a value in ``from_unit`` is multiplied by to express it in ``to_unit`` (both acceleration units
    :func:`acceleration_unit` reads)."""
    units = [acceleration_unit(unit) for unit in (from_unit, to_unit)]
    if None in units:
        unknown = from_unit if units[0] is None else to_unit
        raise BearingTwinError(f"{unknown!r} is not an acceleration unit; give one of {', '.join(METRES_PER_S2)}")
    return METRES_PER_S2[units[0]] / METRES_PER_S2[units[1]]


def convert_acceleration(signal: np.ndarray, from_unit: str, to_unit: str) -> np.ndarray:
    """``signal`` in ``from_unit`` expressed in ``to_unit`` (:func:`acceleration_factor`); along any axis."""
    return np.asarray(signal, dtype=np.float64) * acceleration_factor(from_unit, to_unit)
