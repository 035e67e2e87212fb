"""What a reference record's twin report holds in a new run's config (bearingtwin.twin.reference)."""

import pytest
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError
from bearingtwin.twin.reference import hold_reference


def twin_config(*overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("twin", overrides=["measured.path=unused", "bearing=cwru_6205", *overrides])


def report(fault="outer", race="outer", effects=None):
    fitted = {"interval": [0.0, 1.0], "held": False}
    return {"measured": {"fault": fault, "bearing": "cwru_6205"},
            "operating_point": {"radial_load_n": {"value": 650.0, "unit": "N", **fitted},
                                "clearance_um": {"value": 9.0, "unit": "um", "held": True},
                                "defect_depth_mm": {"value": 0.05, "unit": "mm", **fitted},
                                "defect_width_mm": {"value": 0.4, "unit": "mm", **fitted},
                                "bearing.outer_damping_ns_per_m": {"value": 1234.0, "unit": "", **fitted},
                                "sensor": {"value": "outer race, 60 deg", "race": race, "angle_deg": 60.0}},
            "steps": [{"params": {}}, {"params": effects if effects is not None else
                                       {"resonance": {"natural_frequency_hz": 2500.0, "damping_ratio": 0.05}}}]}


def test_what_the_config_leaves_to_fit_takes_the_references_value_and_what_it_gives_stays():
    cfg = twin_config("operating_point.clearance_um=4.0", "effects=[noise]",
                      "+calibration.base={bearing.outer_damping_ns_per_m: [100.0, 5000.0, log]}")
    held = hold_reference(cfg, report(), "outer")
    assert held.operating_point.radial_load_n == 650.0 and held.operating_point.clearance_um == 4.0
    assert (held.operating_point.defect_depth_mm, held.operating_point.defect_width_mm) == (0.05, 0.4)
    assert (held.operating_point.sensor, held.operating_point.sensor_angle_deg) == ("outer", 60.0)
    assert held.calibration.base_held["bearing.outer_damping_ns_per_m"] == 1234.0
    assert "bearing.outer_damping_ns_per_m" not in held.calibration.base
    assert list(held.effects) == ["resonance", "noise"]  # the reference's first, the config's own after
    assert held.effects.resonance.natural_frequency_hz == 2500.0
    assert list(held.candidates) == list(cfg.candidates)  # the reference's effects stay, to be tried as changed
    assert cfg.operating_point.radial_load_n is None and list(cfg.effects) == ["noise"]  # the given config untouched


def test_a_references_noise_is_held_at_the_absolute_level_its_report_gives():
    """The floor is the sensor's: kept at the reference's level (``noise_reference_rms``), not as a ratio to this twin's
    signal, which a defect grown since would raise. A noise already at an absolute level keeps its own; a report
    without the level (or without noise) leaves the noise as it was fitted."""
    noise = {"snr_db": -20.0, "spectral_slope": 0.5, "reference_rms": None}
    held = hold_reference(twin_config(), {**report(effects={"noise": noise}), "noise_reference_rms": 0.03}, "outer")
    assert dict(held.effects.noise) == {**noise, "reference_rms": 0.03}
    already = {**noise, "reference_rms": 0.5}
    held = hold_reference(twin_config(), {**report(effects={"noise": already}), "noise_reference_rms": 0.03}, "outer")
    assert held.effects.noise.reference_rms == 0.5
    assert hold_reference(twin_config(), report(effects={"noise": noise}), "outer").effects.noise.reference_rms is None
    assert "noise" not in hold_reference(twin_config(), {**report(), "noise_reference_rms": 0.03}, "outer").effects


def test_a_reference_of_another_bearing_state_gives_no_defect_size():
    held = hold_reference(twin_config(), report(fault="normal"), "inner")
    assert held.operating_point.defect_depth_mm is None and held.operating_point.radial_load_n == 650.0


def test_a_sensor_the_config_places_elsewhere_or_another_bearing_is_refused():
    with pytest.raises(BearingTwinError, match=r"^reference: its sensor was on the inner race, operating_point.sensor=outer"):
        hold_reference(twin_config(), report(race="inner"), "outer")
    held = hold_reference(twin_config("operating_point.sensor=outer_y"), report(), "outer")
    assert held.operating_point.sensor == "outer_y" and held.operating_point.sensor_angle_deg is None
    other = report()
    other["measured"]["bearing"] = "cwru_6203"
    with pytest.raises(BearingTwinError, match="bearing cwru_6203, this one of cwru_6205"):
        hold_reference(twin_config(), other, "outer")


CWRU_6205 = {"outer_diameter_mm": 52.0, "inner_diameter_mm": 25.0, "ball_diameter_mm": 7.94, "pitch_diameter_mm": 39.04,
             "n_balls": 9, "contact_angle_deg": 0.0}


def test_a_reference_is_of_the_same_rig_by_its_bearings_geometry_not_its_name():
    """A name says nothing of the geometry: bearing.n_balls=12 under the same name was taken for the same rig."""
    recorded = report()
    recorded["measured"]["geometry"] = dict(CWRU_6205)
    with pytest.raises(BearingTwinError, match=r"^reference: its record's bearing has n_balls=9, this one "
                                               r"bearing.n_balls=12; a reference must come from the same rig"):
        hold_reference(twin_config("bearing.n_balls=12"), recorded, "outer")
    recorded["measured"]["bearing"] = "my6205"  # the same geometry under another name
    assert hold_reference(twin_config("operating_point.clearance_um=4.0"), recorded, "outer").effects.resonance
    # Another bearing config's report, the bearing= left out: the geometry named, and the config whose geometry it is;
    # a name whose config has another geometry is not offered (a name says nothing of the geometry).
    from bearingtwin.config import load_bearing
    from bearingtwin.twin.reference import rig_geometry

    recorded["measured"]["geometry"], recorded["measured"]["bearing"] = rig_geometry(load_bearing("er16k")), "er16k"
    with pytest.raises(BearingTwinError, match=r"a reference must come from the same rig \(the report's bearing is "
                                               r"er16k, this one cwru_6205: give bearing=er16k if this record is of "
                                               r"it, or make the reference again with bearing=cwru_6205\)$"):
        hold_reference(twin_config(), recorded, "outer")
    recorded["measured"]["geometry"]["n_balls"] = 13
    with pytest.raises(BearingTwinError, match=r"must come from the same rig$"):
        hold_reference(twin_config(), recorded, "outer")


def test_a_report_records_the_geometry_a_reference_is_compared_by():
    from bearingtwin.physics.geometry import BearingGeometry
    from bearingtwin.twin.reference import rig_geometry

    geometry = rig_geometry(BearingGeometry.from_config(twin_config().bearing))
    assert geometry == CWRU_6205  # the clearance is the operating point's, held from the reference as such


def test_a_channel_on_the_other_race_and_an_effect_given_twice_are_refused():
    with pytest.raises(BearingTwinError, match=r"operating_point.sensor=inner_y says the inner"):
        hold_reference(twin_config("operating_point.sensor=inner_y"), report(), "outer")
    with pytest.raises(BearingTwinError, match=r"^effects.resonance: the reference already keeps resonance"):
        hold_reference(twin_config("effects=[resonance]"), report(), "outer")


def test_the_candidates_are_the_configs_own():
    """The reference's effects are tried as changed where the config names them among the candidates, not else."""
    held = hold_reference(twin_config("effects=[noise]", "candidates=[resonance,slip]"), report(), "outer")
    assert list(held.candidates) == ["resonance", "slip"] and list(held.effects) == ["resonance", "noise"]
    held = hold_reference(twin_config("candidates=[slip]"), report(), "outer")
    assert list(held.candidates) == ["slip"]


def test_a_report_that_does_not_say_its_bearing_state_gives_no_defect_size():
    unsaid = report()
    del unsaid["measured"]
    held = hold_reference(twin_config(), unsaid, "outer")
    assert held.operating_point.defect_depth_mm is None and held.operating_point.radial_load_n == 650.0


@pytest.mark.parametrize("change, message", [
    (lambda r: r["operating_point"]["sensor"].pop("race"), "operating_point.sensor gives no race"),
    (lambda r: r["operating_point"]["radial_load_n"].update(value="heavy"), "operating_point.radial_load_n has no numeric value"),
    (lambda r: r["steps"][-1].update(params=["resonance"]), "steps\\[-1\\].params is not the final twin's effects"),
    (lambda r: r["operating_point"].pop("sensor"), "operating_point gives no sensor"),
    (lambda r: r.update(steps={"0": {"params": {}}}), "not a twin_report.json"),
    (lambda r: r.update(measured="outer"), "measured is not a mapping"),
    (lambda r: r.update(noise_reference_rms=-0.1), "noise_reference_rms=-0.1 is not a positive number"),
])
def test_a_report_missing_what_a_reference_gives_is_named(tmp_path, change, message):
    import json

    from bearingtwin.twin.reference import read_reference

    broken = report()
    change(broken)
    path = tmp_path / "twin_report.json"
    path.write_text(json.dumps(broken))
    with pytest.raises(BearingTwinError, match=f"^reference={path}: {message}"):
        read_reference(path)
    path.write_text(json.dumps(report()))
    assert read_reference(path)["operating_point"]["radial_load_n"]["value"] == 650.0


def test_an_earlier_runs_out_folder_names_its_report(tmp_path):
    """reference=<out> of the earlier run had been refused as "no such file"; the folder's twin_report.json is read,
    and an out= that is that folder is still refused."""
    import json

    from bearingtwin.twin.reference import read_reference, refuse_reference_folder

    (tmp_path / "earlier").mkdir()
    (tmp_path / "earlier" / "twin_report.json").write_text(json.dumps(report()))
    assert read_reference(tmp_path / "earlier")["operating_point"]["radial_load_n"]["value"] == 650.0
    with pytest.raises(BearingTwinError, match=rf"^reference={tmp_path}/empty/twin_report.json: no such file"):
        (tmp_path / "empty").mkdir()
        read_reference(tmp_path / "empty")
    with pytest.raises(BearingTwinError, match="is the folder of reference="):
        refuse_reference_folder(tmp_path / "earlier", tmp_path / "earlier")
    refuse_reference_folder(tmp_path / "earlier", tmp_path / "later")
