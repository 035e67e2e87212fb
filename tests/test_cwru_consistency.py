"""scripts/cwru_consistency.py: directions agreeing by chance are not called consistent, and a base parameter the
record does not identify is not tabulated as a measured value."""

import numpy as np
import pytest
from script_modules import load_script

from bearingtwin.config import REPO_ROOT

SCRIPT = REPO_ROOT / "scripts" / "cwru_consistency.py"


@pytest.fixture(scope="module")
def consistency():
    return load_script(SCRIPT)


def test_the_rayleigh_test_tells_agreeing_directions_from_random_ones(consistency):
    rng = np.random.default_rng(0)
    # Directions drawn at random: p spreads uniformly over (0, 1), so about 5 % of draws fall below 0.05.
    random_p = [consistency.rayleigh_p(abs(np.mean(np.exp(1j * rng.uniform(0, 2 * np.pi, 13)))), 13)
                for _ in range(2000)]
    assert 0.03 < np.mean(np.array(random_p) < 0.05) < 0.07
    # Thirteen directions within 10 deg of one another agree beyond any chance.
    assert consistency.rayleigh_p(abs(np.mean(np.exp(1j * np.deg2rad(rng.uniform(-10, 10, 13))))), 13) < 1e-4


def test_axial_directions_spread_over_the_half_turn_are_said_to_identify_none(consistency):
    """The 13 fitted directions of the CWRU study (one accelerometer at 12 o'clock): a spread of 46 deg is what
    13 directions at random give, and no direction is identified; 13 near-vertical ones are one direction."""
    study = [91, 0, 0, 0, 0, 150, 0, 120, 60, 30, 120, 120, 30]
    words = consistency._axial_spread(study)
    assert "circular spread 46 deg" in words and "p = 0.37" in words and "no direction is identified" in words
    near_vertical = consistency._axial_spread([85, 90, 95, 88, 92, 271, 89])  # 271 deg is 91 deg, one direction
    assert "mean 90 deg" in near_vertical and "p < 0.01" in near_vertical and "agree more than directions at random" in near_vertical


def test_a_parameter_the_record_does_not_identify_is_not_tabulated_as_a_value(consistency):
    unidentified = {"value": 4224.0, "interval": [20.0, 5000.0], "range": [20.0, 5000.0], "scale": "log"}
    identified = {"value": 861.0, "interval": [700.0, 1000.0], "range": [20.0, 5000.0], "scale": "log"}
    assert consistency._fitted(unidentified, ".0f") == "not identified (20-5000)"
    assert consistency._fitted(identified, ".0f") == "861 (700-1000)"
