"""The guide's worked example of adding an effect (docs/guide.md) runs as written and leaves its signature."""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import yaml
from hydra import compose, initialize_config_dir

import bearingtwin.physics.effect_library as effect_library
from bearingtwin.config import CONF_DIR, REPO_ROOT
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import PLUGIN_GROUP, build_effects, registered_effects
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


def test_the_guides_effect_names_a_bad_value_when_its_config_is_read():
    namespace = dict(vars(effect_library))
    exec(guide_block("python", "class GearMesh"), namespace)
    with pytest.raises(BearingTwinError, match=r"^effects\.gear_mesh\.n_teeth must be a positive integer, got -3$"):
        build_effects({"gear_mesh": {"n_teeth": -3, "level_db": 0.0}})


def test_an_effect_in_a_package_of_ones_own_is_found_through_its_entry_point(tmp_path):
    """The guide's effect kept outside the checkout: a module named under the ``bearingtwin.effects`` entry points
    (an installed package's metadata, here a dist-info folder on the path) and its YAML on hydra.searchpath;
    a fresh ``bearingtwin-simulate`` adds the gear's line without a line of the package changed."""
    (tmp_path / "my_rig_effects.py").write_text("from bearingtwin.physics.effect_library import *\n"
                                                + guide_block("python", "class GearMesh"))
    metadata = tmp_path / "my_rig_effects-0.1.dist-info"
    metadata.mkdir()
    (metadata / "METADATA").write_text("Metadata-Version: 2.1\nName: my-rig-effects\nVersion: 0.1\n")
    (metadata / "entry_points.txt").write_text(f"[{PLUGIN_GROUP}]\ngear_mesh = my_rig_effects\n")
    (tmp_path / "conf" / "effects").mkdir(parents=True)
    (tmp_path / "conf" / "effects" / "gear_mesh.yaml").write_text(guide_block("yaml", "gear_mesh:"))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, "-m", "bearingtwin.cli.simulate", "fault=normal", "simulator.duration=1.0",
                           "effects=[gear_mesh]", f"hydra.searchpath=[file://{tmp_path / 'conf'}]",
                           f"out={tmp_path / 'gear.npz'}"], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    with np.load(tmp_path / "gear.npz") as record:
        signal, fs, rpm = record["signal"], float(record["fs"]), float(record["rpm"])
    spectrum = np.abs(np.fft.rfft(signal)) ** 2
    freqs = np.fft.rfftfreq(signal.size, 1.0 / fs)
    at_mesh = spectrum[np.abs(freqs - 20 * rpm / 60) <= 2.0].sum()
    assert at_mesh > 0.4 * spectrum.sum()  # level_db = 0: the line holds as much power as the bearing signal

    # The twin offers it as a candidate, its nominal parameters read from the YAML on the search path.
    twin = subprocess.run([sys.executable, "-m", "bearingtwin.cli.twin", f"measured.path={tmp_path / 'gear.npz'}",
                           f"hydra.searchpath=[file://{tmp_path / 'conf'}]", "candidates=[gear_mesh,noise]",
                           "operating_point.sensor=inner", "operating_point.sensor_angle_deg=0",
                           "operating_point.radial_load_n=0", f"out={tmp_path / 'twin'}", "tracking.enabled=false",
                           "twin.duration=1.0", "calibration.n_trials_base=3", "calibration.n_trials_effect=6",
                           "calibration.n_trials_refine=3", "calibration.n_polish=3", "calibration.n_polish_effect=2",
                           "ranking.max_effects=1"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert twin.returncode == 0, twin.stderr[-2000:]
    report = json.loads((tmp_path / "twin" / "twin_report.json").read_text())
    assert report["ranking"][0]["effect"] == "gear_mesh", report["ranking"][:2]

    (tmp_path / "my_rig_effects.py").write_text("raise RuntimeError('a bug of its own')\n")
    broken = subprocess.run([sys.executable, "-m", "bearingtwin.cli.simulate", "fault=normal", "effects=[noise]",
                             f"out={tmp_path / 'noise.npz'}"], cwd=tmp_path, env=env, capture_output=True, text=True,
                            timeout=300)
    assert broken.returncode == 2 and broken.stderr.strip().splitlines() == [
        f"error: the effect module my_rig_effects ('{PLUGIN_GROUP}' entry point gear_mesh) fails to import: "
        "RuntimeError: a bug of its own"]
