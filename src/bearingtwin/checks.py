"""Checks of single values a user sets (config keys, command-line options, fields of a file); each
raises :class:`BearingTwinError` naming the field.

A YAML ``true`` is no number here (Python counts it as the integer 1); only :func:`positive_number`
reads a number's text (``fs=12000`` on a command line, a cell of a CSV file). :func:`physical_memory_bytes`
bounds settings whose arrays would not fit (a simulation's length, a data set's windows). :func:`derived_seed`
draws the seed of one part of a run from the run's checked seed.
"""

from __future__ import annotations

import math
import numbers
import os
import sys
from collections.abc import Mapping

from bearingtwin.errors import BearingTwinError


def is_finite_number(value) -> bool:
    """Whether ``value`` is a finite real number (int, float or numpy scalar), not a bool or a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def finite_number(field: str, value, what: str = "a finite number") -> float:
    """``value`` as a float if it is a finite number, else raise ``<field> must be <what>, got <value>``."""
    if not is_finite_number(value):
        raise BearingTwinError(f"{field} must be {what}, got {value!r}")
    return float(value)


def non_negative_number(field: str, value, what: str = "a non-negative number") -> float:
    """``value`` as a float if it is a finite number of at least 0, else raise ``<field> must be <what>, got <value>``."""
    number = finite_number(field, value, what)
    if number < 0:
        raise BearingTwinError(f"{field} must be {what}, got {value!r}")
    return number


def mapping(field: str, value, what: str = "names to values") -> dict:
    """A config block (None: empty) as a dict; anything else (a block the command line replaced by a value) raises
    ``<field> must map <what>, got <value>``."""
    if not isinstance(value or {}, Mapping):
        raise BearingTwinError(f"{field} must map {what}, got {value!r}")
    return dict(value or {})


def whole_number(field: str, value, minimum: int = 1) -> int:
    """``value`` as an int if it is a whole number (``3`` or ``3.0``) of at least ``minimum`` (1: positive,
    0: non-negative)."""
    if not (is_finite_number(value) and int(value) == value and value >= minimum):
        kind = {1: "a positive integer", 0: "a non-negative integer"}.get(minimum, f"an integer of at least {minimum}")
        raise BearingTwinError(f"{field} must be {kind}, got {value!r}")
    return int(value)


def check_seed(seed) -> int:
    """A run's ``seed``: a non-negative int (not 3.0 nor true: it names the run's every random draw)."""
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise BearingTwinError(f"seed must be a non-negative integer, got {seed!r}")
    return seed


def derived_seed(seed: int, *scope: int) -> int:
    """An independent, reproducible seed for one part of a run (a simulated record, a class's search, a candidate's
    screen), drawn from the run's ``seed`` and the part's place ``scope`` (non-negative ints) by numpy's
    ``SeedSequence``: no two parts share one random stream, and a part's seed does not depend on the others."""
    import numpy as np

    return int(np.random.SeedSequence([int(seed), *scope]).generate_state(1)[0])


def positive_number(value, name: str, unit: str, where: str = "") -> float:
    """``value`` (a number, or its text from a command line or a file) as a finite positive float;
    anything else (``12k``, ``0``, ``inf``, ``true``) raises naming ``name`` and its ``unit``."""
    try:
        number = math.nan if isinstance(value, bool) else float(value)  # a YAML true is no rate
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number > 0):
        raise BearingTwinError(f"{where}{name}={value!r} must be a positive number of {unit} (a plain number, no unit)")
    return number


def ball_count(n_balls, ball_diameter_mm: float, pitch_diameter_mm: float) -> int:
    """``bearing.n_balls`` as an int: at least 3 (fewer cannot centre a shaft), and no more than fit on the pitch
    circle: neighbouring centres lie ``pitch x sin(pi / n)`` apart, which must exceed the ball diameter (the two
    diameters positive, finite numbers). The twin's geometry and the test rig's both check their balls here."""
    n_balls = whole_number("bearing.n_balls", n_balls, minimum=3)
    spacing_mm = pitch_diameter_mm * math.sin(math.pi / n_balls)
    if not spacing_mm > ball_diameter_mm:
        raise BearingTwinError(
            f"bearing.n_balls={n_balls} balls of bearing.ball_diameter_mm={ball_diameter_mm:g} overlap on "
            f"bearing.pitch_diameter_mm={pitch_diameter_mm:g}: neighbouring centres lie {spacing_mm:.3g} mm apart "
            "(pitch x sin(180 deg / n_balls)), which must exceed the ball diameter")
    return n_balls


def true_or_false(value, key: str) -> bool:
    """A switch given on the command line: ``true`` or ``false`` (YAML's booleans), anything else refused."""
    if not isinstance(value, bool):
        raise BearingTwinError(f"{key}={value}: give {key}=true or {key}=false")
    return value


def physical_memory_bytes() -> int | None:
    """The machine's physical memory, or None where the system does not say."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def progress_bar_settings(cfg) -> list[tuple[object, str, str]]:
    """The progress bars a training's config sets, as ``(node, name, key)``: Lightning's epoch bar, and the VMD
    features' where the features have one."""
    bars = [(cfg.trainer, "progress_bar", "trainer.progress_bar")]
    return bars + ([(cfg.features, "progress", "features.progress")] if "progress" in cfg.features else [])


def show_progress_bar(setting, in_sweep: bool, key: str = "trainer.progress_bar") -> bool:
    """A progress bar's setting (``key``: Lightning's epoch bar, ``features.progress``: the VMD features'):
    ``auto`` shows it only where someone watches one run (a terminal, not a sweep, whose parallel jobs would
    interleave bars, nor CI)."""
    if isinstance(setting, bool):
        return setting
    if setting != "auto":
        raise BearingTwinError(f"{key} must be auto, true or false, got {setting!r}")
    return not in_sweep and sys.stderr.isatty() and not os.environ.get("CI")
