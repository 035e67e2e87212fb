"""The guide's worked example of adding an effect (docs/guide.md) runs as written and leaves its signature."""

import re

import numpy as np
import pytest
import yaml
from hydra import compose, initialize_config_dir

import bearingtwin.physics.effect_library as effect_library
from bearingtwin.config import CONF_DIR, REPO_ROOT
from bearingtwin.physics.effects import build_effects, registered_effects
from bearingtwin.physics.simulator import simulate


def guide_block(language: str, marker: str) -> str:
    blocks = re.findall(rf"```{language}\n(.*?)```", (REPO_ROOT / "docs" / "guide.md").read_text(), flags=re.S)
    (block,) = [b for b in blocks if marker in b]
    return block


def test_the_guides_effect_is_one_class_and_one_yaml_and_shows_a_line_at_the_gear_mesh_rate():
    namespace = dict(vars(effect_library))  # the example lives in effect_library.py: its imports
    exec(guide_block("python", "class GearMesh"), namespace)
    assert "gear_mesh" in registered_effects()
    effects_cfg = yaml.safe_load(guide_block("yaml", "gear_mesh:"))
    (effect,) = build_effects(effects_cfg)
    assert effect.name == "gear_mesh" and effect.n_teeth == 20

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose(config_name="simulate", overrides=["fault=normal", "simulator.duration=1.0"])
    bare, _ = simulate("normal", cfg.bearing, cfg.simulator)
    with_line, _ = simulate("normal", cfg.bearing, cfg.simulator, effects_cfg)
    # The effect adds a single line and changes nothing else: the difference of the two
    # signals is a sinusoid at 20 times the shaft rate holding the line's power.
    added = with_line.signal - bare.signal
    spectrum = np.abs(np.fft.rfft(added)) ** 2
    freqs = np.fft.rfftfreq(added.size, 1.0 / bare.fs)
    near_line = np.abs(freqs - 20 * cfg.simulator.rpm / 60) <= 2.0
    assert spectrum[near_line].sum() > 0.99 * spectrum.sum()
    line_rms = np.sqrt(np.mean(added**2))
    assert line_rms == pytest.approx(np.sqrt(np.mean(bare.signal**2)), rel=0.02)  # level_db = 0: the signal's RMS
