"""``bearingtwin-simulate``: simulate one bearing state and write it to an ``.npz`` (and plots).

    bearingtwin-simulate fault=outer simulator.rpm=1797 simulator.fs=10000 simulator.duration=2.0 out=/tmp/run.npz
"""

from __future__ import annotations

import shlex
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
import numpy as np
from omegaconf import DictConfig, OmegaConf

from bearingtwin.cli.summary import closing_summary
from bearingtwin.checks import show_progress_bar, true_or_false
from bearingtwin.config import (bearing_overrides, exit_on_user_error, hydra_command, load_bearing, output_folder,
                                refuse_unknown_keys, search_path_override)
from bearingtwin.data.formats import save_simulated_record
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.lifecycle import stop_cleanly
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.simulator import CHANNELS, oversample_factor, simulate
from bearingtwin.twin.operating_point import in_downward_load_frame


def _plot(out: Path, signal: np.ndarray, fs: float, rpm: float, fault: str, geometry: BearingGeometry) -> list[Path]:
    """Time signal and envelope spectrum with the defect frequencies and harmonics marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bearingtwin.signal.envelope import envelope_spectrum

    paths = [out.with_name(out.stem + "_signal.png"), out.with_name(out.stem + "_envelope.png")]
    figure, axis = plt.subplots(figsize=(9, 3.5))
    shown = min(signal.size, int(0.2 * fs))
    axis.plot(np.arange(shown) / fs, signal[:shown], lw=0.7)
    axis.set(xlabel="time (s)", ylabel="acceleration (m/s$^2$)", title=f"{fault}: first {shown / fs:.2f} s")
    figure.tight_layout()
    figure.savefig(paths[0], dpi=120)
    plt.close(figure)

    freqs, amplitude = envelope_spectrum(signal, fs)
    frequencies = geometry.defect_frequencies(rpm)
    figure, axis = plt.subplots(figsize=(9, 3.5))
    band = freqs <= 5.0 * frequencies["bpfi"]
    axis.plot(freqs[band], amplitude[band], lw=0.7, color="k")
    for (name, color) in (("bpfo", "tab:red"), ("bpfi", "tab:blue"), ("bsf", "tab:green")):
        for harmonic in (1, 2, 3):
            axis.axvline(harmonic * frequencies[name], color=color, ls="--", lw=0.8,
                         label=f"{name.upper()} {frequencies[name]:.2f} Hz" if harmonic == 1 else None)
    axis.set(xlabel="frequency (Hz)", ylabel="envelope amplitude (m/s$^2$)", title=f"{fault}: envelope spectrum")
    axis.legend(loc="upper right")
    figure.tight_layout()
    figure.savefig(paths[1], dpi=120)
    plt.close(figure)
    return paths


OUTPUT_SETTINGS = ("out", "plot", "progress")
"""The command line's settings of where and how the record is written, not of what it is."""

DEFECT_FREQUENCY_GEOMETRY = ("n_balls", "ball_diameter_mm", "pitch_diameter_mm", "contact_angle_deg")
"""The bearing's settings its defect frequencies depend on."""


def geometry_changed(cfg: DictConfig) -> bool:
    """Whether the bearing simulated has another geometry than its config's (``bearing.n_balls=12``): a record
    naming the config would then misstate its defect frequencies, which a reader takes from the named config."""
    simulated, named = BearingGeometry.from_config(cfg.bearing), load_bearing(HydraConfig.get().runtime.choices.get("bearing"))
    return any(getattr(simulated, name) != getattr(named, name) for name in DEFECT_FREQUENCY_GEOMETRY)


def record_facts(cfg: DictConfig, fault: str, notes: list[str], changed_geometry: bool) -> dict:
    """What a simulated record states beside its samples: the bearing config it was made with (none where the
    command line changed its geometry: ``changed_geometry``), and the settings a reader cannot see in it (load, sensor direction,
    defect, effects, seed, and every setting the command line changed) and the simulation's ``notes`` (a defect no loaded ball met), so a folder of simulated
    files describes itself."""
    simulator = cfg.simulator
    facts = {"load_x_n": simulator.load_x_n, "load_y_n": simulator.load_y_n, "seed": simulator.seed,
             "effects": ", ".join(cfg.effects) or "none",
             # Every setting the command line changed (a clearance, the masses, an oversampling, an unbalance,
             # gravity): what the record was made with beyond the named bearing config's.
             "settings": " ".join(override for override in HydraConfig.get().overrides.task
                                  if override.partition("=")[0].lstrip("+~") not in OUTPUT_SETTINGS)}
    if simulator.get("sensor_angle_deg") is not None:
        facts["sensor_angle_deg"] = simulator.sensor_angle_deg
    if fault != "normal":
        facts.update(defect_width_mm=simulator.defect.width_mm, defect_depth_mm=simulator.defect.depth_mm,
                     defect_position=defect_position(simulator.defect, fault))
    if changed_geometry:  # no config names it: its geometry in words, for a reader to see whose lines these are
        bearing = cfg.bearing
        facts["bearing_geometry"] = (f"{bearing.n_balls} balls of {bearing.ball_diameter_mm:g} mm on a "
                                     f"{bearing.pitch_diameter_mm:g} mm pitch, contact angle "
                                     f"{bearing.get('contact_angle_deg') or 0:g} deg")
    else:
        facts["bearing"] = HydraConfig.get().runtime.choices.get("bearing")
    if notes:
        facts["simulation_notes"] = "; ".join(notes)  # not "notes": a reader keeps its own list of notes there
    return facts


def twin_command(out: Path, bearing_name: str | None, bearing: DictConfig, simulator: DictConfig, sensor: str,
                 overrides: list[str] = ()) -> str:
    """The ``bearingtwin-twin`` call for a simulated record, holding what the simulation set and no file states:
    the bearing, the sensor's race and direction and the radial load (held by a user who knows their rig), and the
    oversampling it was made with; the twin's own defaults (a housing sensor, a loaded rig) would otherwise be
    fitted to a record they cannot match. ``overrides``: the command line's of the bearing's settings, held too.
    A load in another direction than down is held as the twin can hold it (:func:`in_downward_load_frame`)."""
    words = [f"bearingtwin-twin measured.path={out}"]
    if bearing_name and bearing_name != "paper":
        words.append(f"bearing={bearing_name}")
        words += [shlex.quote(override) for override in search_path_override()]  # where a bearing of one's own is
    words += [shlex.quote(override) for override in overrides]  # the bearing the record was made with
    race, axis = sensor.split("_")
    angle = simulator.get("sensor_angle_deg")
    angle, load = in_downward_load_frame(
        float(angle) if angle is not None else (0.0 if axis == "x" else 90.0),
        float(simulator.get("load_x_n") or 0.0), float(simulator.get("load_y_n") or 0.0),
        float(bearing.inner_mass_kg) * float(simulator.get("gravity_m_per_s2") or 0.0))
    # "+ 0.0" below: a zero prints as 0, never -0
    words += [f"operating_point.sensor={race}", f"operating_point.sensor_angle_deg={round(angle, 1) + 0.0:g}"]
    if load is not None:
        words.append(f"operating_point.radial_load_n={round(load, 1) + 0.0:g}")
    if oversample_factor(simulator) > 1:  # the twin heard as the record was: anti-aliased alike
        words.append(f"simulator.oversample={oversample_factor(simulator)}")
    return " ".join(words)


def defect_position(defect: DictConfig, fault: str) -> str:
    """Where the defect of a ``fault`` record sits, in words."""
    return {"outer": "at the centre of the load zone" if defect.outer_angle_deg is None
            else f"at {defect.outer_angle_deg % 360:g} deg (0: 3 o'clock, 90: 12 o'clock)",  # as the note says it
            "inner": f"at {defect.inner_angle_deg:g} deg from the shaft's start", "ball": f"on ball {defect.ball_index}"}[fault]


def defect_words(defect: DictConfig, fault: str, sinks_m: float | None = None) -> str:
    """The defect a record was made with, as its summary says it: with ``sinks_m``, how far a ball's centre
    sinks into it (a ball rests on the edges of a pit narrower than itself: physics/defects.py)."""
    sinks = ("" if sinks_m is None else f" (the ball sinks {sinks_m * 1e6:.3g} um as it meets the outer race)"
             if fault == "ball" else f" (a ball sinks {sinks_m * 1e6:.3g} um into it)")
    return f"{defect.width_mm:g} mm wide, {defect.depth_mm:g} mm deep{sinks}, {defect_position(defect, fault)}"


@hydra_command("simulate")
@exit_on_user_error
def simulate_command(cfg: DictConfig) -> None:
    refuse_unknown_keys(HydraConfig.get())
    out = Path(cfg.out).expanduser()
    if out.suffix.lower() != ".npz":  # numpy would write <out>.npz and leave <out> for the user to look for
        raise BearingTwinError(f"out={cfg.out}: bearingtwin-simulate writes an .npz archive; give out=<name>.npz")
    output_folder(out.parent)
    plot = true_or_false(cfg.plot, "plot")
    # The bar (auto: in a terminal, for one simulation) as the twin's and training's, never into a log unless asked.
    progress = show_progress_bar(cfg.progress, in_sweep=HydraConfig.get().mode == RunMode.MULTIRUN, key="progress")
    recording, channels = simulate(cfg.fault, cfg.bearing, cfg.simulator, cfg.effects, progress=progress)
    changed = geometry_changed(cfg)
    try:
        save_simulated_record(out, recording, channels, CHANNELS,
                              record_facts(cfg, recording.fault, recording.meta.get("notes", []), changed))
    except OSError as error:  # a full disk, a file-size limit: nothing written, an earlier file there kept
        raise BearingTwinError(f"out={cfg.out}: cannot be written ({error.strerror or error}); nothing was written, "
                               "and a file already there is as it was") from None
    written = [out]
    if plot:
        written += _plot(out, recording.signal, recording.fs, recording.rpm, recording.fault,
                         BearingGeometry.from_config(cfg.bearing))
    bearing, simulator = cfg.bearing, cfg.simulator
    facts = {
        "record": f"{recording.fault}, {recording.signal.size / recording.fs:g} s at {recording.fs:g} Hz, "
                  f"{recording.rpm:g} rpm, sensor {recording.channel} (m/s^2)",
        "bearing": f"{HydraConfig.get().runtime.choices.get('bearing')} ({bearing.n_balls} balls of {bearing.ball_diameter_mm:g} mm "
                   f"on a {bearing.pitch_diameter_mm:g} mm pitch, clearance {1000 * bearing.clearance_mm:g} um)"
                   + (f", its geometry changed by {' '.join(bearing_overrides())}: the file names no bearing config, "
                      "whose defect frequencies would be another bearing's (the twin call below holds these overrides, "
                      "as bearingtwin-inspect takes them; a model reads a bearing by its conf/bearing file: write one "
                      "for this bearing to diagnose with bearing=<name>)" if changed else ""),
        "load": f"{simulator.load_x_n:g} N along x, {simulator.load_y_n:g} N along y"
                + (", and the inner ring's weight" if simulator.get("gravity_m_per_s2") else " (no gravity)"),
        **({"defect": defect_words(simulator.defect, recording.fault, recording.meta.get("defect_depth_m"))}
           if recording.fault != "normal" else {}),
        **({"note": "; ".join(recording.meta["notes"])} if recording.meta.get("notes") else {}),
        # A setting left at null takes its default behaviour: "reference_rms None" would read as a missing value.
        "effects": "; ".join(f"{name} ({', '.join(f'{key} {value}' for key, value in params.items() if value is not None)})"
                             for name, params in OmegaConf.to_container(cfg.effects, resolve=True).items()) or "none",
        "written": ", ".join(path.name for path in written),
        "next": twin_command(out.resolve(), HydraConfig.get().runtime.choices.get("bearing"), cfg.bearing, cfg.simulator,
                             cfg.simulator.sensor, bearing_overrides()) + " holds the twin against this record",
    }
    print(closing_summary("bearingtwin-simulate", facts, out=str(out.parent.resolve())))


main = stop_cleanly(simulate_command)  # Ctrl-C: one line and exit 130, not a traceback from inside the work

if __name__ == "__main__":
    main()
