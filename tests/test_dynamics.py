"""Contact stiffness, equations of motion, static equilibrium, defects and the effects hook."""

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.optimize
import scipy.special
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics import effects as effects_module
from bearingtwin.physics.contact import (bearing_contact_stiffness, combined_contact_stiffness,
                                         point_contact_stiffness, race_contact_radii)
from bearingtwin.physics.defects import build_defect, defect_depths, max_drop_m
from bearingtwin.physics.dynamics import DynamicParameters, contact_force, state_derivative, static_equilibrium
from bearingtwin.physics.effects import Effect, build_effects, register_effect
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.simulator import simulate
from bearingtwin.physics.solvers.fast import derivative
from bearingtwin.signal.envelope import envelope_spectrum, peak_near

STEEL = dict(youngs_modulus_pa=206e9, poisson_ratio=0.3)
BEARING = OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml")
CWRU = OmegaConf.merge(BEARING, {"name": "cwru_6205", "pitch_diameter_mm": 39.04})
SIMULATOR = OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml")
GEOMETRY = BearingGeometry.from_config(BEARING)


def params(**changes):
    return DynamicParameters.from_config(OmegaConf.merge(BEARING, changes), SIMULATOR)


def exact_hertz_stiffness(rx, ry, youngs_modulus_pa, poisson_ratio):
    """Hertz solution with exact elliptic integrals: the ellipse's eccentricity e solves
    (a/b)^2 [E(e) - (1 - e^2) K(e)] / [K(e) - E(e)] = Ry / Rx (Johnson, Contact Mechanics, eq. 4.39)."""
    ratio = ry / rx

    def mismatch(m):
        k_m, e_m = scipy.special.ellipk(m), scipy.special.ellipe(m)
        return (e_m - (1 - m) * k_m) / (k_m - e_m) / (1 - m) - ratio

    m = scipy.optimize.brentq(mismatch, 1e-9, 1 - 1e-12)
    ellipticity = 1 / math.sqrt(1 - m)
    radius = 1 / (1 / rx + 1 / ry)
    modulus = youngs_modulus_pa / (1 - poisson_ratio**2)
    return math.pi * ellipticity * modulus * math.sqrt(
        2 * scipy.special.ellipe(m) * radius / (9 * scipy.special.ellipk(m) ** 3))


def test_sphere_limit_is_the_classical_hertz_law():
    # Two spheres: P = 4/3 E* sqrt(R) delta^1.5 with 1/E* = 2 (1 - nu^2) / E (Johnson eq. 4.23).
    radius = 0.004
    effective_radius = radius / 2
    e_star = 206e9 / (2 * (1 - 0.3**2))
    assert point_contact_stiffness(effective_radius, effective_radius, **STEEL) == pytest.approx(
        4 / 3 * e_star * math.sqrt(effective_radius), rel=1e-12)


@pytest.mark.parametrize("race", ["inner", "outer"])
def test_hamrock_brewe_within_3_percent_of_exact_hertz_for_a_6205(race):
    radii = race_contact_radii(BearingGeometry.from_config(CWRU), 0.52)[race]
    assert point_contact_stiffness(*radii, **STEEL) == pytest.approx(exact_hertz_stiffness(*radii, **STEEL), rel=0.03)


def test_6205_contact_stiffness_is_in_the_published_class():
    # Harris & Kotzalas-type values for a 6205-size deep-groove ball bearing (steel, f = 0.52) are
    # ~8-13 x 10^9 N/m^1.5 for the ball's two contacts in series; the exact Hertz solution of the same
    # geometry gives 9.2 x 10^9 (computed above), the approximation must stay within 3 % of it.
    geometry = BearingGeometry.from_config(CWRU)
    derived = bearing_contact_stiffness(geometry, 206.0, 0.3, 0.52)
    radii = race_contact_radii(geometry, 0.52)
    exact = combined_contact_stiffness(*(exact_hertz_stiffness(*radii[r], **STEEL) for r in ("inner", "outer")))
    assert 8e9 < derived < 13e9
    assert derived == pytest.approx(exact, rel=0.03)


def test_a_configured_contact_stiffness_overrides_the_derivation():
    assert params(contact_stiffness_n_per_m1_5=5e9).contact_stiffness_n_per_m1_5 == 5e9
    assert params().contact_stiffness_n_per_m1_5 == pytest.approx(
        bearing_contact_stiffness(GEOMETRY, 206.0, 0.3, 0.52))
    with pytest.raises(BearingTwinError, match="bearing.groove_radius_factor"):
        params(groove_radius_factor=0.4)


def test_static_equilibrium_carries_the_weight_through_the_balls_at_the_bottom():
    p = params()
    angles = 2 * np.pi * np.arange(9) / 9 + 0.1
    state = static_equilibrium(p, angles)
    force_x, force_y = contact_force(state, angles, np.zeros(9), p)
    inner_weight = p.inner_mass_kg * p.gravity_m_per_s2
    # inner race: the balls hold its weight (its soft support spring carries the rest)
    assert force_y + p.inner_stiffness_n_per_m * state[1] == pytest.approx(-inner_weight, rel=1e-6)
    # together the two supports carry both weights
    assert -p.outer_stiffness_n_per_m * state[3] - p.inner_stiffness_n_per_m * state[1] == pytest.approx(
        inner_weight + p.outer_mass_kg * p.gravity_m_per_s2, rel=1e-6)
    deflection = (state[0] - state[2]) * np.cos(angles) + (state[1] - state[3]) * np.sin(angles) - p.clearance_m
    assert np.all(np.sin(angles[deflection > 0]) < 0)  # only balls in the lower half are loaded
    assert abs(force_x) < 1e-3 * inner_weight


def test_numba_kernel_and_python_rhs_give_the_same_derivative():
    rng = np.random.default_rng(0)
    p = params()
    p = DynamicParameters(**{**p.__dict__, "eccentricity_m": 2e-5, "load_x_n": 30.0, "load_y_n": -100.0})
    out = np.empty(8)
    n_in_contact = 0
    for _ in range(50):
        state = np.concatenate([rng.normal(0, 1e-5, 4), rng.normal(0, 1e-2, 4)])
        angles = rng.uniform(0, 2 * np.pi, 9)
        depths = rng.uniform(0, 5e-6, 9) * (rng.random(9) < 0.3)
        shaft_angle, shaft_speed = rng.uniform(0, 100), rng.uniform(50, 300)
        expected = state_derivative(state, angles, depths, shaft_angle, shaft_speed, p)
        derivative(state, np.cos(angles), np.sin(angles), depths, shaft_angle, shaft_speed, p.as_array(), out)
        np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-9)
        n_in_contact += np.any(contact_force(state, angles, depths, p) != 0)
    assert n_in_contact > 40  # the states exercise the Hertz contacts, not only the springs


def test_a_narrow_defect_limits_how_deep_the_ball_sinks():
    defect_cfg = dict(SIMULATOR.defect)
    ball = GEOMETRY.ball_radius_m
    flat = ball - math.sqrt(ball**2 - (0.533e-3 / 2) ** 2)
    assert flat == pytest.approx(8.955e-6, rel=1e-3)
    outer = build_defect("outer", GEOMETRY, defect_cfg, -math.pi / 2)
    inner = build_defect("inner", GEOMETRY, defect_cfg, -math.pi / 2)
    assert outer.depth_m < flat < inner.depth_m  # concave outer race meets the ball sooner, convex inner later
    assert outer.depth_m == pytest.approx(max_drop_m(ball, 0.533e-3, GEOMETRY.outer_race_radius_m, False))
    shallow = build_defect("outer", GEOMETRY, {**defect_cfg, "depth_mm": 0.001}, -math.pi / 2)
    assert shallow.depth_m == pytest.approx(1e-6)  # a shallow pit is felt at its real depth
    assert outer.angle_rad == -math.pi / 2  # centred in the load zone by default
    with pytest.raises(BearingTwinError, match="simulator.defect.depth_mm"):
        build_defect("outer", GEOMETRY, {**defect_cfg, "depth_mm": -0.1}, 0.0)
    with pytest.raises(BearingTwinError, match="simulator.defect.width_mm"):
        build_defect("outer", GEOMETRY, {**defect_cfg, "width_mm": 9.0}, 0.0)


def test_defect_profile_is_smooth_and_as_wide_as_the_defect():
    defect = build_defect("outer", GEOMETRY, dict(SIMULATOR.defect), 0.0)
    sweep = np.linspace(-2 * defect.half_angle_rad, 2 * defect.half_angle_rad, 4001)
    depths = np.empty(9)
    profile = []
    for angle in sweep:
        defect_depths(defect.as_array(), angle + 2 * np.pi * np.arange(9) / 9, 0.0, 0.0, depths)
        profile.append(depths[0])
    profile = np.array(profile)
    arc_width = np.ptp(sweep[profile > 0]) * GEOMETRY.outer_race_radius_m
    assert arc_width == pytest.approx(0.533e-3, rel=2e-3)
    assert profile.max() == pytest.approx(defect.depth_m, rel=1e-6)
    assert np.max(np.abs(np.diff(profile))) < 0.01 * defect.depth_m  # no jump anywhere, edges included


def test_ball_defect_meets_outer_then_inner_race_each_once_per_spin():
    defect = build_defect("ball", GEOMETRY, dict(SIMULATOR.defect), 0.0)
    spins = np.linspace(0, 2 * np.pi, 20001, endpoint=False)
    depths = np.empty(9)
    seen = []
    for spin in spins:
        defect_depths(defect.as_array(), 2 * np.pi * np.arange(9) / 9, 0.0, spin, depths)
        assert np.count_nonzero(depths[1:]) == 0
        seen.append(depths[0])
    seen = np.array(seen)
    assert seen[np.abs(spins - np.pi) < 0.1].max() == pytest.approx(defect.inner_strike_depth_m, rel=1e-4)
    assert seen[(spins < 0.1) | (spins > 2 * np.pi - 0.1)].max() == pytest.approx(defect.depth_m, rel=1e-4)
    touching = (seen > 0).astype(int)
    assert np.count_nonzero(np.diff(np.append(touching, touching[0])) == 1) == 2  # two strikes per spin, cyclically


# ---------------------------------------------------------------- effects hook

@register_effect
class HookProbe(Effect):
    """A test-only effect touching all three stages: unbalance, a frozen cage, a sensor gain with noise."""

    name = "hook_probe"

    def __init__(self, eccentricity_mm=0.0, freeze_cage=False, gain=1.0, noise=0.0):
        self.eccentricity_mm, self.freeze_cage, self.gain, self.noise = eccentricity_mm, freeze_cage, gain, noise

    def modify_parameters(self, params):
        return DynamicParameters(**{**params.__dict__, "eccentricity_m": self.eccentricity_mm / 1000})

    def modify_kinematics(self, kinematics, rng):
        if not self.freeze_cage:
            return kinematics
        return replace(kinematics, cage_angle_rad=np.full_like(kinematics.cage_angle_rad, kinematics.cage_angle_rad[0]))

    def modify_signal(self, signal, fs, rng, shaft_hz):
        return self.gain * signal + self.noise * rng.standard_normal(signal.size)


SHORT = OmegaConf.merge(SIMULATOR, {"duration": 1.0})


def test_effects_are_empty_by_default_and_unknown_names_fail():
    assert build_effects({}) == []
    assert build_effects(OmegaConf.create({})) == []
    with pytest.raises(BearingTwinError, match="effects.no_such_effect"):
        build_effects({"no_such_effect": {}})
    with pytest.raises(BearingTwinError, match="effects.hook_probe"):
        build_effects({"hook_probe": {"no_such_parameter": 1}})
    assert "hook_probe" in effects_module.registered_effects()


def test_effect_hook_reaches_parameters_kinematics_and_signal():
    bare, bare_channels = simulate("normal", BEARING, SHORT)
    shaft_hz = 1797 / 60
    # modify_parameters: an unbalance appears as a 1x shaft-speed line in the spectrum
    unbalanced, _ = simulate("normal", BEARING, SHORT, {"hook_probe": {"eccentricity_mm": 0.01}})
    spectrum = lambda x: np.abs(np.fft.rfft(x)) / x.size
    freqs = np.fft.rfftfreq(bare.signal.size, 1 / bare.fs)
    line = np.argmin(np.abs(freqs - shaft_hz))
    assert spectrum(unbalanced.signal)[line] > 10 * spectrum(bare.signal)[line]
    # modify_kinematics: with the cage held still no ball passes, so the BPFO (varying-compliance) line goes
    frozen, _ = simulate("normal", BEARING, SHORT, {"hook_probe": {"freeze_cage": True}})
    f, amplitude = envelope_spectrum(np.stack([bare.signal, frozen.signal]), bare.fs)
    _, (moving_line, frozen_line) = peak_near(f, amplitude, GEOMETRY.bpfo_hz(1797), 1.0)
    assert frozen_line < 0.01 * moving_line
    # modify_signal: the sensor path acts on the sensor channel only, seeded from simulator.seed
    noisy, noisy_channels = simulate("normal", BEARING, SHORT, {"hook_probe": {"gain": 2.0, "noise": 0.1}})
    again, _ = simulate("normal", BEARING, SHORT, {"hook_probe": {"gain": 2.0, "noise": 0.1}})
    reseeded, _ = simulate("normal", BEARING, OmegaConf.merge(SHORT, {"seed": 1}), {"hook_probe": {"gain": 2.0, "noise": 0.1}})
    np.testing.assert_array_equal(noisy.signal, again.signal)
    assert not np.array_equal(noisy.signal, reseeded.signal)
    np.testing.assert_allclose(noisy_channels, bare_channels)
    assert np.std(noisy.signal - 2 * bare.signal) == pytest.approx(0.1, rel=0.05)
