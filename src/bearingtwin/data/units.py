"""Acceleration units a record may state, and conversion between them.

Records come in m/s^2 (the twin, many loggers) or in g (CWRU, most accelerometer data sheets):
the same vibration differs by a factor of standard gravity (``scipy.constants.g``, 9.80665 m/s^2
per g) between the two, which every amplitude-dependent feature sees.
"""

from __future__ import annotations

import numpy as np
import scipy.constants

from bearingtwin.errors import BearingTwinError

METRES_PER_S2 = {"m/s^2": 1.0, "g": scipy.constants.g}
"""Each acceleration unit's value in m/s^2, by the unit's canonical spelling."""

_SPELLINGS = {"m/s^2": "m/s^2", "m/s2": "m/s^2", "m/s**2": "m/s^2", "m/s²": "m/s^2", "m s^-2": "m/s^2", "m s-2": "m/s^2",
              "ms^-2": "m/s^2", "ms-2": "m/s^2", "g": "g", "gn": "g", "g0": "g"}


def acceleration_unit(unit: str) -> str | None:
    """The canonical spelling (``m/s^2`` or ``g``) of an acceleration unit a file states (``G``, ``m/s2`` and
    other spellings read too); None for any other unit (``V``, ``mm/s``) or none."""
    return _SPELLINGS.get(" ".join(str(unit).split()).lower())


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
